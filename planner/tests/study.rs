//! Study helpers: the median and the shipped segment reference table.

use planner::study::{median, segments};

#[test]
fn median_of_odd_and_even_counts() {
    assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    assert!(median(&mut []).is_nan());
}

#[test]
fn shipped_reference_lists_ten_segments() {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config"))
        .join(segments::REFERENCE_CSV);
    let rows = segments::load_reference(&path).expect("shipped reference loads");
    assert_eq!(rows.len(), 10);
    assert_eq!(rows[0].0, "S01");
    assert!((rows[0].1 - 9.2046).abs() < 1e-9);
    assert!(rows.iter().all(|(_, t, it)| *t > 1.0 && *it > 0));
}

#[test]
fn malformed_reference_is_a_typed_error() {
    let path = std::env::temp_dir().join(format!("bad-ref-{}.csv", std::process::id()));
    std::fs::write(&path, "segment,t_N,iterations,status\nS01,abc,3,x\n").unwrap();
    let err = segments::load_reference(&path).unwrap_err();
    assert!(err.to_string().contains("line 2"), "{err}");
    let _ = std::fs::remove_file(&path);
}
