//! A real browser for the report's end-to-end tests and the monitor's
//! benchmark: Debian's headless Chromium driven over the W3C WebDriver
//! protocol by `chromedriver`.
//!
//! The client is the few WebDriver commands its users need (new session,
//! navigate, execute a script, find an element, click, screenshot), JSON
//! over HTTP/1.1 on the loopback, written on `std` and `serde_json` alone:
//! a WebDriver crate would bring an HTTP client stack for a handful of
//! loopback requests. The browser runs without a sandbox (the tests run as
//! root in CI) and without any background networking, which a machine
//! with no network would refuse.
//!
//! Every call says what went wrong as an error: the tests turn it into a
//! failure, the benchmark into a row that says why it was not measured.
//! Only tests and the benchmark harness use it: nothing that flies or
//! serves a page may depend on a browser.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{mpsc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// A program on the PATH (or named by `env`), or an error that says what
/// to install.
fn program(env: &str, names: &[&str]) -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os(env) {
        return Ok(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    for dir in std::env::split_paths(&path) {
        for name in names {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return Ok(candidate);
            }
        }
    }
    Err(format!(
        "no {} on the PATH (nor {env} set): install the Debian packages `chromium` and \
         `chromium-driver` (scripts/test does)",
        names[0]
    ))
}

/// Whether a browser can be started here (both programs found).
pub fn available() -> bool {
    program("EAMOS_CHROMIUM", &["chromium", "chromium-browser"]).is_ok()
        && program("EAMOS_CHROMEDRIVER", &["chromedriver"]).is_ok()
}

/// A chromedriver process and one browser session in it; both end on drop.
pub struct Browser {
    /// Behind a lock so that a failed request can ask whether it exited.
    driver: Mutex<Child>,
    port: u16,
    session: String,
    _profile: tempfile::TempDir,
}

impl Browser {
    /// A headless Chromium with a window of `width` by `height` pixels.
    pub fn start(width: u32, height: u32) -> Result<Browser, String> {
        Browser::start_with(width, height, &[])
    }

    /// The same, with more command-line switches for Chromium (the
    /// benchmark's `--js-flags=--expose-gc`, for one).
    pub fn start_with(width: u32, height: u32, switches: &[&str]) -> Result<Browser, String> {
        let chromium = program("EAMOS_CHROMIUM", &["chromium", "chromium-browser"])?;
        let chromedriver = program("EAMOS_CHROMEDRIVER", &["chromedriver"])?;
        // The driver picks its own free port and says which: a port the
        // caller picked (bound, closed, handed over) could be picked again
        // by a browser started at the same moment, whose driver would then
        // fail to listen, leaving both browsers on one driver until the
        // first to end killed it under the other.
        let mut driver = Command::new(&chromedriver)
            .arg("--port=0")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", chromedriver.display()))?;
        let port = match listening_port(&mut driver) {
            Ok(port) => port,
            Err(e) => {
                let _ = driver.kill();
                let _ = driver.wait();
                return Err(format!("{}: {e}", chromedriver.display()));
            }
        };
        let profile = tempfile::tempdir().map_err(|e| e.to_string())?;
        let mut b = Browser {
            driver: Mutex::new(driver),
            port,
            session: String::new(),
            _profile: profile,
        };
        let mut args = vec![
            "--headless".to_string(),
            "--no-sandbox".into(),
            "--disable-gpu".into(),
            "--disable-quic".into(),
            "--no-first-run".into(),
            "--disable-background-networking".into(),
            "--disable-component-update".into(),
            "--disable-sync".into(),
            "--disable-dev-shm-usage".into(),
            "--hide-scrollbars".into(),
            format!("--user-data-dir={}", b._profile.path().display()),
            format!("--window-size={width},{height}"),
        ];
        args.extend(switches.iter().map(|s| s.to_string()));
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": chromium, "args": args},
        }}});
        let v = b
            .request("POST", "/session", Some(caps))
            .map_err(|e| format!("no browser session: {e}"))?;
        b.session = v["sessionId"]
            .as_str()
            .ok_or_else(|| format!("no session: {v}"))?
            .to_string();
        Ok(b)
    }

    /// Opens a file of this machine.
    pub fn open(&self, file: &Path) -> Result<(), String> {
        let file = file
            .canonicalize()
            .map_err(|e| format!("{}: {e}", file.display()))?;
        let url = format!("file://{}", file.display());
        self.command("POST", "url", json!({ "url": url })).map(drop)
    }

    /// Opens `url` (a page served on this machine, such as the monitor's).
    pub fn navigate(&self, url: &str) -> Result<(), String> {
        self.command("POST", "url", json!({ "url": url })).map(drop)
    }

    /// Runs `script` (a function body: `return ...`) in the page.
    pub fn eval(&self, script: &str) -> Result<Value, String> {
        self.command(
            "POST",
            "execute/sync",
            json!({"script": script, "args": []}),
        )
    }

    /// Waits up to `limit` until `script` returns true.
    pub fn wait_until(&self, script: &str, limit: Duration) -> Result<(), String> {
        let started = Instant::now();
        while self.eval(script)? != Value::Bool(true) {
            if started.elapsed() > limit {
                return Err(format!("still not true after {limit:?}: {script}"));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        Ok(())
    }

    fn element(&self, selector: &str) -> Result<String, String> {
        let v = self.command(
            "POST",
            "element",
            json!({"using": "css selector", "value": selector}),
        )?;
        v[ELEMENT]
            .as_str()
            .map(str::to_string)
            .ok_or_else(|| format!("no element {selector}: {v}"))
    }

    pub fn click(&self, selector: &str) -> Result<(), String> {
        let e = self.element(selector)?;
        self.command("POST", &format!("element/{e}/click"), json!({}))
            .map(drop)
    }

    /// A PNG of the window, or of one element.
    pub fn screenshot(&self, selector: Option<&str>) -> Result<Vec<u8>, String> {
        let v = match selector {
            Some(s) => {
                // Chromium clips an element's picture to the window.
                self.eval(&format!(
                    "document.querySelector({}).scrollIntoView();",
                    Value::from(s)
                ))?;
                let e = self.element(s)?;
                self.command("GET", &format!("element/{e}/screenshot"), Value::Null)?
            }
            None => self.command("GET", "screenshot", Value::Null)?,
        };
        let png = base64(v.as_str().ok_or("no base64 screenshot")?);
        if !png.starts_with(b"\x89PNG") {
            return Err("the screenshot is not a PNG".into());
        }
        Ok(png)
    }

    fn command(&self, method: &str, path: &str, body: Value) -> Result<Value, String> {
        let path = format!("/session/{}/{path}", self.session);
        let body = (method == "POST").then_some(body);
        self.request(method, &path, body)
            .map_err(|e| format!("{method} {path}: {e}{}", self.driver_gone()))
    }

    /// What to add to a failed request's error when the driver has
    /// exited: then its end of the connection is what went away.
    fn driver_gone(&self) -> String {
        let mut driver = self.driver.lock().unwrap_or_else(|e| e.into_inner());
        match driver.try_wait() {
            Ok(Some(status)) => format!(" (chromedriver has exited: {status})"),
            _ => String::new(),
        }
    }

    /// One WebDriver request; its `value`, or the error it answered.
    fn request(&self, method: &str, path: &str, body: Option<Value>) -> Result<Value, String> {
        let mut s = TcpStream::connect(("127.0.0.1", self.port)).map_err(|e| e.to_string())?;
        s.set_read_timeout(Some(Duration::from_secs(60))).ok();
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let head = format!(
            "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: application/json\r\n\
             Content-Length: {}\r\nConnection: close\r\n\r\n",
            self.port,
            body.len()
        );
        s.write_all(head.as_bytes()).map_err(|e| e.to_string())?;
        s.write_all(body.as_bytes()).map_err(|e| e.to_string())?;
        // chromedriver keeps the connection open: read the header, then
        // as many bytes as it says.
        let mut raw = Vec::new();
        let mut buf = [0u8; 65536];
        let split = loop {
            if let Some(i) = raw.windows(4).position(|w| w == b"\r\n\r\n") {
                break i;
            }
            let n = s.read(&mut buf).map_err(|e| e.to_string())?;
            if n == 0 {
                return Err("the connection closed before a header".into());
            }
            raw.extend_from_slice(&buf[..n]);
        };
        let head = String::from_utf8_lossy(&raw[..split]).to_ascii_lowercase();
        let length = head
            .lines()
            .find_map(|l| l.strip_prefix("content-length:"))
            .and_then(|v| v.trim().parse::<usize>().ok());
        let mut payload = raw[split + 4..].to_vec();
        match length {
            Some(len) => {
                while payload.len() < len {
                    let n = s.read(&mut buf).map_err(|e| e.to_string())?;
                    if n == 0 {
                        break;
                    }
                    payload.extend_from_slice(&buf[..n]);
                }
            }
            None => {
                s.read_to_end(&mut payload).map_err(|e| e.to_string())?;
                if head.contains("transfer-encoding: chunked") {
                    payload = unchunk(&payload);
                }
            }
        }
        let v: Value = serde_json::from_slice(&payload).map_err(|e| e.to_string())?;
        let status = head.split_whitespace().nth(1).unwrap_or("");
        if status != "200" {
            return Err(format!("HTTP {status}: {}", v["value"]));
        }
        Ok(v["value"].clone())
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let path = format!("/session/{}", self.session);
            let _ = self.request("DELETE", &path, None);
        }
        let driver = self.driver.get_mut().unwrap_or_else(|e| e.into_inner());
        let _ = driver.kill();
        let _ = driver.wait();
    }
}

/// The port a driver started with `--port=0` announces ("... started
/// successfully on port N."); its output is drained afterwards, so that a
/// full pipe never stops it.
fn listening_port(driver: &mut Child) -> Result<u16, String> {
    let out = driver.stdout.take().ok_or("no output from the driver")?;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut said = Vec::new();
        let mut lines = BufReader::new(out).lines().map_while(Result::ok);
        let reply = loop {
            let Some(line) = lines.next() else {
                break Err(format!("it ended without listening: {}", said.join(" / ")));
            };
            let port = line
                .split("started successfully on port ")
                .nth(1)
                .and_then(|rest| rest.trim_end_matches('.').parse::<u16>().ok());
            match port {
                Some(port) => break Ok(port),
                None => said.push(line),
            }
        };
        let _ = tx.send(reply);
        lines.for_each(drop);
    });
    rx.recv_timeout(Duration::from_secs(20))
        .map_err(|_| "it did not say where it listens within 20 s".to_string())?
}

fn unchunk(mut data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = data.windows(2).position(|w| w == b"\r\n") {
        let size =
            usize::from_str_radix(String::from_utf8_lossy(&data[..eol]).trim(), 16).unwrap_or(0);
        if size == 0 {
            break;
        }
        out.extend_from_slice(&data[eol + 2..eol + 2 + size]);
        data = &data[eol + 2 + size + 2..];
    }
    out
}

fn base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let digits: Vec<u8> = text.bytes().filter_map(value).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for c in digits.chunks(4) {
        let n = c
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &d)| n | (d as u32) << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..c.len()]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn saying(text: &str) -> Child {
        Command::new("sh")
            .args(["-c", &format!("printf '{text}'")])
            .stdout(Stdio::piped())
            .spawn()
            .expect("sh")
    }

    #[test]
    fn a_driver_is_listening_on_the_port_it_announces() {
        let said = "Starting ChromeDriver on port 0\\nChromeDriver was started successfully on port 41234.\\n";
        assert_eq!(listening_port(&mut saying(said)), Ok(41234));
    }

    #[test]
    fn a_driver_that_ends_without_announcing_a_port_is_an_error_with_what_it_said() {
        let said = "Starting ChromeDriver on port 0\\nIPv6 port not available. Exiting...\\n";
        let e = listening_port(&mut saying(said)).unwrap_err();
        assert_eq!(
            e,
            "it ended without listening: Starting ChromeDriver on port 0 / IPv6 port not available. Exiting..."
        );
    }
}
