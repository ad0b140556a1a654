//! Damaged and foreign files: a clear error and exit code 2, never a panic; and a
//! property test that drives the reader with a few hundred mutated files. (Files cut
//! short are recovered: `crash_recovery.rs`.)

mod common;

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;
use std::process::Command;

use plan_record::{ReadError, Recording};

/// Runs `replay run FILE` and returns (exit code, stderr).
fn replay_run(file: &Path) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_replay"))
        .arg("run")
        .arg(file)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn check_cli(name: &str, bytes: &[u8], expect: &str) {
    let d = common::temp_dir(name);
    let f = d.join(format!("{name}.mcap"));
    std::fs::write(&f, bytes).unwrap();
    for sub in ["run", "info"] {
        let out = Command::new(env!("CARGO_BIN_EXE_replay"))
            .arg(sub)
            .arg(&f)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name} {sub}: {err}");
        assert!(!err.contains("panicked"), "{name} {sub}: {err}");
        assert!(
            err.contains(expect),
            "{name} {sub}: expected `{expect}` in: {err}"
        );
        assert!(
            err.contains(&f.display().to_string()),
            "{name}: names the file: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn empty_file() {
    assert!(matches!(Recording::from_bytes(&[]), Err(ReadError::Empty)));
    check_cli("empty", &[], "empty file");
}

#[test]
fn truncated_file_is_recovered_not_refused() {
    let b = common::valid_bytes();
    let full = Recording::from_bytes(b).unwrap();
    assert!(full.complete());
    for cut in [1, 8, 100, 141, b.len() / 2, b.len() - 9, b.len() - 1] {
        let r = Recording::from_bytes(&b[..cut]).unwrap();
        let rec = r.recovery.as_ref().expect("a cut file is not complete");
        assert_eq!(rec.kept_bytes + rec.dropped_bytes, cut as u64, "cut {cut}");
        assert_eq!(r.inputs[..], full.inputs[..r.inputs.len()], "cut {cut}");
        assert_eq!(r.outputs[..], full.outputs[..r.outputs.len()], "cut {cut}");
    }
}

#[test]
fn corrupt_chunk() {
    let b = common::valid_bytes();
    // Flip a byte in the middle of the first chunk's messages (a recorded double).
    let mut c = b.to_vec();
    let at = c.len() / 4;
    c[at] ^= 0x40;
    let e = Recording::from_bytes(&c).unwrap_err();
    assert!(e.to_string().contains("CRC"), "{e}");
    check_cli("corrupt", &c, "Chunk CRC failed");
}

#[test]
fn wrong_schema() {
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(Cursor::new(Vec::new()))
        .unwrap();
    let s = w
        .add_schema(
            "geometry_msgs/msg/Point",
            "ros2msg",
            b"float64 x\nfloat64 y\nfloat64 z\n",
        )
        .unwrap();
    let ch = w
        .add_channel(s, "/planner/input", "cdr", &BTreeMap::new())
        .unwrap();
    let msg = [
        0u8, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    ];
    w.write_to_known_channel(
        &mcap::records::MessageHeader {
            channel_id: ch,
            sequence: 0,
            log_time: 1,
            publish_time: 1,
        },
        &msg,
    )
    .unwrap();
    w.finish().unwrap();
    let bytes = w.into_inner().into_inner();
    let e = Recording::from_bytes(&bytes).unwrap_err();
    assert!(matches!(e, ReadError::WrongSchema { .. }), "{e}");
    check_cli("schema", &bytes, "geometry_msgs/msg/Point");
}

#[test]
fn planner_schema_with_the_right_name_but_another_definition_is_refused() {
    use plan_record::schema::{
        INPUT_TOPIC, MESSAGE_ENCODING, PLAN_INPUT_MSG, PLAN_INPUT_NAME, SCHEMA_ENCODING,
    };
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(Cursor::new(Vec::new()))
        .unwrap();
    // An older layout under the same name: one field renamed.
    let old = PLAN_INPUT_MSG.replacen("settings", "solver_settings", 1);
    assert_ne!(old, PLAN_INPUT_MSG);
    let s = w
        .add_schema(PLAN_INPUT_NAME, SCHEMA_ENCODING, old.as_bytes())
        .unwrap();
    w.add_channel(s, INPUT_TOPIC, MESSAGE_ENCODING, &BTreeMap::new())
        .unwrap();
    w.finish().unwrap();
    let bytes = w.into_inner().into_inner();
    let e = Recording::from_bytes(&bytes).unwrap_err();
    assert!(matches!(e, ReadError::WrongSchema { .. }), "{e}");
    assert!(e.to_string().contains("different definition"), "{e}");
    check_cli("schema_text", &bytes, "different definition");
}

#[test]
fn valid_mcap_without_planner_inputs_cannot_be_replayed() {
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .create(Cursor::new(Vec::new()))
        .unwrap();
    w.finish().unwrap();
    let bytes = w.into_inner().into_inner();
    let d = common::temp_dir("noinputs");
    let f = d.join("none.mcap");
    std::fs::write(&f, &bytes).unwrap();
    let (code, err) = replay_run(&f);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("no planner inputs"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn not_an_mcap_file() {
    let e = Recording::from_bytes(b"solver.toml: tol = 1e-6\n").unwrap_err();
    assert!(matches!(e, ReadError::Mcap { .. }), "{e}");
}

/// xorshift64*: a deterministic pseudo-random stream for the mutations.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

#[test]
fn mutated_files_give_ok_or_err_never_a_panic() {
    let valid = common::valid_bytes();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut ok, mut err, mut recovered) = (0, 0, 0);
    for case in 0..400 {
        let mut b = valid.to_vec();
        match case % 5 {
            // Flip 1..8 random bits anywhere.
            0 | 1 => {
                for _ in 0..1 + rng.below(8) {
                    let i = rng.below(b.len());
                    b[i] ^= 1 << rng.below(8);
                }
            }
            // Truncate at a random point.
            2 => b.truncate(rng.below(b.len())),
            // Overwrite a random 8-byte run (lengths, offsets, opcodes) with random bytes.
            3 => {
                let i = rng.below(b.len() - 8);
                b[i..i + 8].copy_from_slice(&rng.next().to_le_bytes());
            }
            // Remove or duplicate a random span.
            _ => {
                let i = rng.below(b.len());
                let n = 1 + rng.below(64).min(b.len() - i - 1);
                if rng.below(2) == 0 {
                    b.drain(i..i + n);
                } else {
                    let span = b[i..i + n].to_vec();
                    b.splice(i..i, span);
                }
            }
        }
        let result = std::panic::catch_unwind(|| Recording::from_bytes(&b));
        match result {
            Ok(Ok(r)) if r.complete() => ok += 1,
            // Read as cut short: detected, and what was read is a prefix of the original.
            Ok(Ok(r)) => {
                let full = Recording::from_bytes(valid).unwrap();
                assert_eq!(r.inputs[..], full.inputs[..r.inputs.len()], "case {case}");
                recovered += 1;
            }
            Ok(Err(e)) => {
                assert!(!e.to_string().is_empty());
                err += 1;
            }
            Err(_) => panic!("case {case}: the reader panicked on a mutated file"),
        }
    }
    eprintln!(
        "of 400 mutated files, {err} rejected, {recovered} read as cut short, {ok} read fine"
    );
    // CRCs cover every byte that matters, so nearly every mutation must be detected.
    assert!(
        err + recovered > 350,
        "only {} of 400 mutations detected ({ok} read fine)",
        err + recovered
    );
}

#[test]
fn mutated_cdr_payloads_give_ok_or_err_never_a_panic() {
    // The MCAP CRCs stop nearly every damaged file before decoding; drive the CDR decoder
    // directly so its bounds checks are exercised too.
    use plan_record::cdr::{decode_input, decode_output, encode_input, encode_output, Encoder};
    let rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    let mut enc = Encoder::default();
    encode_input(&mut enc, &rec.inputs[0]);
    let input = enc.bytes().to_vec();
    encode_output(&mut enc, &rec.outputs[0]);
    let output = enc.bytes().to_vec();
    assert_eq!(decode_input(&input).unwrap(), rec.inputs[0]);
    assert_eq!(decode_output(&output).unwrap(), rec.outputs[0]);
    let mut rng = Rng(42);
    let mut err = 0;
    for case in 0..400 {
        let base = if case % 2 == 0 { &input } else { &output };
        let mut b = base.clone();
        match case % 3 {
            0 => {
                let i = rng.below(b.len() - 4);
                b[i..i + 4].copy_from_slice(&(rng.next() as u32).to_le_bytes());
            }
            1 => b.truncate(rng.below(b.len())),
            _ => {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
        }
        let r = std::panic::catch_unwind(|| {
            if case % 2 == 0 {
                decode_input(&b).map(|_| ())
            } else {
                decode_output(&b).map(|_| ())
            }
        });
        match r {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                assert!(
                    e.to_string().contains("byte") || e.to_string().contains("header"),
                    "{e}"
                );
                err += 1;
            }
            Err(_) => panic!("case {case}: the CDR decoder panicked"),
        }
    }
    // Flipped doubles decode fine (any bits are valid); truncations never do.
    assert!(err >= 133, "{err}");
}

/// Writes the valid two-plan recording changed by `change` and runs `replay run` and
/// `replay info` on it: each must exit with `code` and say `expect` (stdout or stderr).
fn run_and_info_agree(name: &str, change: impl Fn(&mut Recording), code: i32, expect: &str) {
    let mut rec = Recording::from_bytes(common::valid_bytes()).unwrap();
    change(&mut rec);
    let d = common::temp_dir(name);
    let f = d.join(format!("{name}.mcap"));
    plan_record::write_recording(&rec, &f).unwrap();
    for sub in ["run", "info"] {
        let out = Command::new(env!("CARGO_BIN_EXE_replay"))
            .arg(sub)
            .arg(&f)
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(out.status.code(), Some(code), "{name} {sub}: {text}");
        assert!(!text.contains("panicked"), "{name} {sub}: {text}");
        assert!(
            text.contains(expect),
            "{name} {sub}: expected `{expect}` in: {text}"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn run_and_info_both_refuse_a_repeated_input_seq() {
    run_and_info_agree(
        "dup_seq",
        |r| r.inputs[1].seq = r.inputs[0].seq,
        2,
        &format!("two planner inputs with seq {}", common_seq()),
    );
}

/// The seq of the fixture's first input.
fn common_seq() -> u64 {
    Recording::from_bytes(common::valid_bytes()).unwrap().inputs[0].seq
}

#[test]
fn run_and_info_both_refuse_a_nan_horizon_length_naming_seq_and_field() {
    let seq = common_seq();
    run_and_info_agree(
        "nan_length",
        |r| r.inputs[0].length_m = f64::NAN,
        2,
        &format!("recorded input {seq}: OCP field length: NaN"),
    );
}

#[test]
fn an_input_beyond_the_curvature_centre_is_a_bad_file_not_a_difference() {
    let seq = common_seq();
    run_and_info_agree(
        "absurd_kappa",
        |r| r.inputs[0].kappa[5] = 1e308,
        2,
        &format!("recorded input {seq}: OCP field e_max[5]"),
    );
    run_and_info_agree(
        "absurd_kappa_text",
        |r| r.inputs[0].kappa[5] = 1e308,
        2,
        "curvature centre of kappa[5] = 1e308",
    );
}

#[test]
fn an_output_that_matches_no_input_exits_1_with_its_seq() {
    run_and_info_agree(
        "orphan_output",
        |r| r.outputs[1].seq = 999,
        1,
        "match no input and cannot be verified: seq 999",
    );
}
