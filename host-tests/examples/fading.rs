//! How ghosts fade in the changing scenes, with and without decay (`fading::measure`): a
//! table per scene.
//!
//! ```sh
//! cargo run --release -p terrain-pyramid-host-tests --example fading
//! ```
use terrain_pyramid_host_tests::fading::{measure, ClearTimes};
use terrain_pyramid_host_tests::sim::changing::ChangingScene;

fn secs(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |s| format!("{s:.1}"))
}

fn times(t: &ClearTimes) -> String {
    format!(
        "{}/{} cleared, median {} s, p90 {} s, max {} s",
        t.cleared,
        t.cells,
        secs(t.median_s),
        secs(t.p90_s),
        secs(t.max_s)
    )
}

fn main() {
    for scene in ChangingScene::all() {
        let started = std::time::Instant::now();
        let result = match measure(&scene) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{}: {e}", scene.name);
                std::process::exit(1);
            }
        };
        println!(
            "## {} ({:.0} s, {} lines, {} mover cells left between {:?} s; {:.1} s to run)",
            result.scene,
            result.duration_s,
            result.lines,
            result.mover_cells,
            result.left_s,
            started.elapsed().as_secs_f64()
        );
        for run in &result.runs {
            println!(
                "- decay {} {}: fused {}",
                run.decay.mode,
                run.decay
                    .tau_s
                    .map_or_else(String::new, |t| format!("tau {t:.2} s")),
                times(&run.fused)
            );
            for (k, l) in run.layers.iter().enumerate() {
                if l.cells > 0 {
                    println!("    layer {k}: {}", times(l));
                }
            }
            println!(
                "    static in view wrongly cleared {}/{} ({:.1} %), out of view {}/{} ({:.1} %); {} cells faded",
                run.static_in_view.cleared,
                run.static_in_view.cells,
                100.0 * run.static_in_view.share,
                run.static_out_of_view.cleared,
                run.static_out_of_view.cells,
                100.0 * run.static_out_of_view.share,
                run.cells_faded
            );
        }
    }
}
