//! The real browser of the page tests (`eamos_browser`: headless Chromium
//! over WebDriver), each failure a test failure: a test that needs a
//! browser never passes without one.

use std::path::Path;
use std::time::Duration;

use serde_json::Value;

fn or_fail<T>(what: &str, r: Result<T, String>) -> T {
    r.unwrap_or_else(|e| panic!("{what}: {e}"))
}

pub struct Browser(eamos_browser::Browser);

impl Browser {
    /// A headless Chromium with a window of `width` by `height` pixels.
    pub fn start(width: u32, height: u32) -> Browser {
        Browser(or_fail(
            "a browser",
            eamos_browser::Browser::start(width, height),
        ))
    }

    /// Opens a file of this machine.
    pub fn open(&self, file: &Path) {
        or_fail("open", self.0.open(file))
    }

    /// Opens `url` (a page a test serves, such as the monitor's).
    pub fn navigate(&self, url: &str) {
        or_fail("navigate", self.0.navigate(url))
    }

    /// Runs `script` (a function body: `return ...`) in the page.
    pub fn eval(&self, script: &str) -> Value {
        or_fail("script", self.0.eval(script))
    }

    /// Waits (up to five seconds) until `script` returns true: what a
    /// page does on an event (a followed link's `hashchange`) comes after
    /// the click that caused it has returned.
    pub fn wait_for(&self, script: &str) {
        or_fail("wait", self.0.wait_until(script, Duration::from_secs(5)))
    }

    /// Waits up to `limit` until `script` returns true (a live page,
    /// fed by a flight on a loaded machine); fails with `what` if not.
    pub fn wait_long(&self, script: &str, limit: Duration, what: &str) {
        or_fail(what, self.0.wait_until(script, limit))
    }

    /// The number of elements `selector` finds.
    pub fn count(&self, selector: &str) -> u64 {
        let script = format!(
            "return document.querySelectorAll({}).length;",
            Value::from(selector)
        );
        self.eval(&script)
            .as_u64()
            .unwrap_or_else(|| panic!("no count for {selector}"))
    }

    pub fn click(&self, selector: &str) {
        or_fail(selector, self.0.click(selector))
    }

    /// A PNG of the window, or of one element, written to `to`.
    pub fn screenshot(&self, selector: Option<&str>, to: &Path) {
        let png = or_fail("screenshot", self.0.screenshot(selector));
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::write(to, png).unwrap();
    }
}
