//! An independent PNML reader, pm4py, loads the net of every paper mission
//! with the same places, transitions, arcs and initial marking. This test
//! fails (it does not skip) when python3 or pm4py is missing: `scripts/test`
//! installs pm4py.

mod common;

use std::process::Command;

use common::*;
use eamos_petri::export::pnml::{pt_counts, to_pnml, PnmlOptions};

const READER: &str = r#"
import json, sys
import pm4py
out = []
for path in sys.argv[1:]:
    net, im, fm = pm4py.read_pnml(path)
    out.append({
        "path": path,
        "places": len(net.places),
        "transitions": len(net.transitions),
        "arcs": len(net.arcs),
        "marked": sorted(p.name for p in im),
    })
print("EAMOS-COUNTS " + json.dumps(out))
"#;

#[test]
fn pm4py_reads_every_paper_mission_with_the_same_counts() {
    let dir = tempfile::tempdir().unwrap();
    let mut expected = Vec::new();
    let mut nets: Vec<(String, eamos_petri::Net)> =
        PAPER.iter().map(|s| (s.to_string(), paper(s).1)).collect();
    nets.push(("showcase".into(), showcase()));
    for (stem, net) in &nets {
        for final_loop in [false, true] {
            let opts = PnmlOptions {
                final_loop,
                locate: None,
            };
            let path = dir.path().join(format!("{stem}-{final_loop}.pnml"));
            std::fs::write(&path, to_pnml(net, &opts)).unwrap();
            let mut marked: Vec<String> = net
                .initial_marking
                .iter()
                .map(|&p| net.id(p).to_string())
                .collect();
            marked.sort();
            expected.push((path, pt_counts(net, &opts), marked));
        }
    }
    let out = Command::new("python3")
        .arg("-c")
        .arg(READER)
        .args(expected.iter().map(|(p, _, _)| p))
        .output()
        .expect(
            "python3 must be installed (with pm4py) to check PNML against an independent reader",
        );
    assert!(
        out.status.success(),
        "pm4py could not read the nets (is it installed? `pip install pm4py`): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("EAMOS-COUNTS "))
        .expect("the reader prints its counts");
    let read: Vec<serde_json::Value> = serde_json::from_str(line).unwrap();
    assert_eq!(read.len(), expected.len());
    for (got, (path, (places, transitions, arcs), marked)) in read.iter().zip(&expected) {
        let what = path.display();
        assert_eq!(got["places"], *places, "{what}");
        assert_eq!(got["transitions"], *transitions, "{what}");
        assert_eq!(got["arcs"], *arcs, "{what}");
        let got_marked: Vec<String> = got["marked"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect();
        assert_eq!(&got_marked, marked, "{what}");
    }
}
