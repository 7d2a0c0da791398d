//! A driver that went away under its browser is named in the next
//! request's error. A file of its own: it kills every chromedriver its
//! process started, which would take the drivers of other tests running
//! beside it in one binary.

use std::time::Duration;

use eamos_browser::Browser;

/// The chromedrivers this process started, by their process ids.
fn own_drivers() -> Vec<u32> {
    let me = std::process::id().to_string();
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let stat = std::fs::read_to_string(entry.path().join("stat")).unwrap_or_default();
        // pid (comm) state ppid ...
        let Some((head, rest)) = stat.split_once(") ") else {
            continue;
        };
        let parent = rest.split_whitespace().nth(1);
        if head.ends_with("(chromedriver") && parent == Some(me.as_str()) {
            found.extend(
                head.split_whitespace()
                    .next()
                    .and_then(|p| p.parse::<u32>().ok()),
            );
        }
    }
    found
}

/// The next request says the driver exited, not only that the
/// connection closed.
#[test]
fn a_request_to_a_driver_that_exited_says_so() {
    let b = Browser::start(400, 300).unwrap_or_else(|e| panic!("a browser: {e}"));
    for pid in own_drivers() {
        let killed = std::process::Command::new("kill")
            .args(["-9", &pid.to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
    }
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    let e = loop {
        let e = b
            .navigate("data:text/html,<p>gone</p>")
            .expect_err("no driver to answer");
        if e.contains("chromedriver has exited") || std::time::Instant::now() > deadline {
            break e;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(e.contains("chromedriver has exited"), "{e}");
}
