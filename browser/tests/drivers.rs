//! Each browser has a driver of its own. Tests start browsers at the same
//! moment (libtest runs them on parallel threads) and end them whenever
//! they are done; a browser that shared another's driver would lose it
//! mid-test when the other ended (seen in CI: a page test's navigation
//! answered by a closed connection).

use std::time::Duration;

use eamos_browser::Browser;

fn page(text: &str) -> String {
    format!("data:text/html,<p id=t>{text}</p>")
}

fn started_together(n: usize) -> Vec<Browser> {
    let started: Vec<_> = (0..n)
        .map(|_| std::thread::spawn(|| Browser::start(400, 300)))
        .collect();
    started
        .into_iter()
        .map(|t| {
            t.join()
                .unwrap()
                .unwrap_or_else(|e| panic!("a browser: {e}"))
        })
        .collect()
}

/// Whichever of two browsers started together ends first, the other
/// still opens a page and runs its scripts.
#[test]
fn of_two_browsers_started_together_either_outlives_the_other() {
    for first in 0..2 {
        let mut browsers = started_together(2);
        drop(browsers.remove(first));
        let left = &browsers[0];
        left.navigate(&page("left")).unwrap();
        left.wait_until(
            "return document.getElementById('t').textContent === 'left';",
            Duration::from_secs(10),
        )
        .unwrap_or_else(|e| panic!("with browser {first} ended first: {e}"));
    }
}
