//! The changing scenes through the application core (`fading`), held to what decay is for:
//! the door's ghost (the closed door's cells, read as obstacles when it opened) clears sooner
//! with decay, every ghost cell clears, and no static obstacle in view is cleared by it.
use terrain_pyramid::DecayMode;
use terrain_pyramid_host_tests::fading::{measure_simulated, DecaySetting};
use terrain_pyramid_host_tests::sim::changing::{simulate_changing, ChangingScene};
use terrain_pyramid_host_tests::sim::trajectory::Trajectory;

#[test]
fn the_open_door_leaves_no_ghost_with_decay() {
    let mut scene = ChangingScene::door();
    // The door opens at 10 s; 14 s after that are enough for τ = 2 s.
    scene.trajectory = Trajectory::standing(24.0);
    let sim = simulate_changing(&scene).unwrap();
    let settings = [
        DecaySetting::OFF,
        DecaySetting::every_layer(DecayMode::All, 2.0),
    ];
    let result = measure_simulated(scene.name, &sim, &settings).unwrap();
    assert!(result.mover_cells > 0);
    let (off, on) = (&result.runs[0], &result.runs[1]);
    assert!(
        on.fused.cells > 0,
        "the door's cells were obstacles: {on:?}"
    );
    assert_eq!(on.fused.cleared, on.fused.cells, "{on:?}");
    // Without decay the ghost outlives the run, or clears later.
    let later = off.fused.cleared < off.fused.cells
        || off.fused.max_s.unwrap_or(f64::INFINITY) > on.fused.max_s.unwrap_or(0.0);
    assert!(later, "off {:?} on {:?}", off.fused, on.fused);
    assert!(on.cells_faded > 0 && off.cells_faded == 0);
    // The wall in view stays an obstacle.
    assert!(on.static_in_view.cells > 0);
    assert_eq!(on.static_in_view.cleared, 0, "{on:?}");
}
