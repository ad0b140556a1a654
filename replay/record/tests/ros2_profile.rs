//! A recording declares the MCAP `ros2` profile in its header, and its channels carry what
//! that profile requires: `ros2msg` schemas and `cdr` messages.

use mcap::read::LinearReader;
use mcap::records::Record as McapRecord;
use plan_record::schema::{MESSAGE_ENCODING, PROFILE, SCHEMA_ENCODING};
use plan_record::{PlanOutput, Record, Recorder};

#[test]
fn a_recording_declares_the_ros2_profile_with_ros2msg_schemas_and_cdr_messages() {
    let dir = std::env::temp_dir().join(format!("plan-record-ros2-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("run.mcap");
    let rec = Recorder::create(&path, 4).unwrap();
    rec.record(Record::Output(Box::new(PlanOutput::with_capacity(4))));
    rec.finish().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let (mut profile, mut schemas, mut channels) = (None, 0, 0);
    for record in LinearReader::new(&bytes).unwrap() {
        match record.unwrap() {
            McapRecord::Header(h) => profile = Some(h.profile),
            McapRecord::Schema { header, .. } => {
                assert_eq!(header.encoding, "ros2msg");
                schemas += 1;
            }
            McapRecord::Channel(c) => {
                assert_eq!(c.message_encoding, "cdr");
                channels += 1;
            }
            _ => {}
        }
    }
    assert_eq!(profile.as_deref(), Some("ros2"));
    assert_eq!(
        (PROFILE, SCHEMA_ENCODING, MESSAGE_ENCODING),
        ("ros2", "ros2msg", "cdr")
    );
    assert!(
        schemas >= 2 && channels >= 2,
        "{schemas} schemas, {channels} channels"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The message paths (`/topic.field`) of a Foxglove layout's panels.
fn layout_paths(v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::String(s) if s.starts_with("/planner/") => out.push(s.clone()),
        serde_json::Value::Array(a) => a.iter().for_each(|x| layout_paths(x, out)),
        serde_json::Value::Object(o) => o.values().for_each(|x| layout_paths(x, out)),
        _ => {}
    }
}

#[test]
fn the_shipped_foxglove_layout_plots_fields_the_recording_has() {
    use plan_record::schema::{INPUT_TOPIC, OUTPUT_TOPIC, PLAN_INPUT_MSG, PLAN_OUTPUT_MSG};
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/foxglove/trajopt-layout.json");
    let layout: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let mut paths = Vec::new();
    layout_paths(&layout["configById"], &mut paths);
    assert!(paths.len() >= 8, "{paths:?}");
    for p in &paths {
        let (topic, field) = p.split_once('.').unwrap();
        let array = field.ends_with("[:]");
        let name = field.trim_end_matches("[:]");
        let schema = match topic {
            t if t == OUTPUT_TOPIC => PLAN_OUTPUT_MSG,
            t if t == INPUT_TOPIC => PLAN_INPUT_MSG,
            t => panic!("{p}: unknown topic {t}"),
        };
        let declared = schema.lines().any(|l| {
            let mut w = l.split_whitespace();
            match (w.next(), w.next()) {
                (Some(ty), Some(n)) => n == name && ty.ends_with("[]") == array,
                _ => false,
            }
        });
        assert!(declared, "{p}: not a field of {topic}");
    }
    for field in ["v[:]", "beta[:]", "delta[:]", "e[:]"] {
        assert!(
            paths.iter().any(|p| p.ends_with(field)),
            "{field} is plotted"
        );
    }
}
