//! `lab experiments --far-obstacles-only --quick --json`: the far-obstacles experiment runs,
//! its JSON object holds both rules with every ring and kind, its counts add up to the fused
//! map at the returns, and its table (stderr with `--json`, and `report.md`) holds every ring
//! and every kind that has returns.
mod common;

use common::run_lab;
use serde_json::Value;

fn n(v: &Value) -> u64 {
    v.as_u64().unwrap_or_else(|| panic!("not a count: {v}"))
}

#[test]
fn the_quick_far_obstacles_table_holds_every_ring_and_kind() {
    let dir = std::env::temp_dir().join(format!("pyramid-far-obstacles-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (json, table) = run_lab(
        &[
            "experiments",
            "--far-obstacles-only",
            "--quick",
            "--json",
            "--out",
        ],
        &dir,
    );
    let far = &json["far_obstacles"];
    assert_eq!(json["quick"], true);
    assert_eq!(far["setup"]["xs"].as_array().map(Vec::len), Some(3));
    let rings: Vec<&str> = far["rings"]
        .as_array()
        .expect("the rings")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert_eq!(rings, ["0-5 m", "5-10 m", "10-15 m", "15-20 m"]);
    let rules = far["rules"].as_array().expect("the rules");
    let names: Vec<&str> = rules.iter().filter_map(|r| r["rule"].as_str()).collect();
    assert_eq!(names, ["plane (default)", "spread (paper)"]);
    let report = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
    for rule in rules {
        let name = rule["rule"].as_str().unwrap_or_default();
        // The table: a section per rule, every ring a column.
        let section = table
            .split("\n### ")
            .find(|s| s.starts_with(name))
            .unwrap_or_else(|| panic!("no table for {name}:\n{table}"));
        assert!(report.contains(section.trim_end()), "report.md differs");
        let head = section
            .lines()
            .find(|l| l.starts_with("| returns on |"))
            .expect("the table's head");
        for ring in &rings {
            assert!(head.contains(ring), "{ring} missing: {head}");
        }
        // Clear ground in every ring, and on most of it the map reads navigable.
        let ground = rule["ground"].as_array().expect("ground");
        assert_eq!(ground.len(), 4);
        assert!(ground.iter().all(|g| n(&g["points"]) > 0), "{rule}");
        assert!(rule["ground_navigable_pct"]
            .as_f64()
            .is_some_and(|p| p > 50.0));
        // Every kind with its four rings; every kind with returns a row of the table.
        let kinds = rule["kinds"].as_array().expect("kinds");
        let kind_names: Vec<&str> = kinds.iter().filter_map(|k| k["kind"].as_str()).collect();
        assert_eq!(kind_names, ["curb", "post", "step edge", "block", "other"]);
        let (mut points, mut marked) = (0, 0);
        for k in kinds {
            let per_ring = k["rings"].as_array().expect("rings");
            assert_eq!(per_ring.len(), 4);
            let sum: u64 = per_ring.iter().map(|r| n(&r["points"])).sum();
            assert_eq!(sum, n(&k["all"]["points"]));
            points += sum;
            marked += per_ring.iter().map(|r| n(&r["right"])).sum::<u64>();
            let kind = k["kind"].as_str().unwrap_or_default();
            if sum > 0 {
                assert!(
                    section
                        .lines()
                        .any(|l| l.starts_with(&format!("| {kind} |"))),
                    "{kind} has returns but no row:\n{section}"
                );
            }
        }
        // The street's curbs, poles, car and facade are all seen.
        for kind in ["curb", "post", "block"] {
            let k = kinds.iter().find(|k| k["kind"] == kind).expect("kind");
            assert!(n(&k["all"]["points"]) > 0, "no returns on {kind}");
        }
        // The rings and kinds add up to the fused map at the returns.
        let fp = &rule["fused_points"];
        assert_eq!(points, n(&fp["obstacle"]), "{rule}");
        assert_eq!(marked, n(&fp["obstacle_ok"]), "{rule}");
        let ground_points: u64 = ground.iter().map(|g| n(&g["points"])).sum();
        let ground_right: u64 = ground.iter().map(|g| n(&g["right"])).sum();
        assert_eq!(ground_points, n(&fp["navigable"]), "{rule}");
        assert_eq!(ground_right, n(&fp["navigable_ok"]), "{rule}");
    }
    assert!(dir.join("results.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}
