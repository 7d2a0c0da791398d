//! Deploy sessions: every `eamos deploy` offers its slices and starts them
//! in a fresh session, and an agent starts each session at most once,
//! remembered on its disk (see the crate's "Replay").

use std::path::{Path, PathBuf};

/// The deploy sessions an agent has started. Kept on the agent's disk, so
/// that a restarted agent, which holds no slice and no memory, still
/// refuses a recorded offer and start played back to it.
#[derive(Debug, Default)]
pub struct Sessions {
    path: Option<PathBuf>,
    started: std::collections::BTreeSet<String>,
}

impl Sessions {
    /// The sessions recorded in `path` (none if it does not exist yet).
    pub fn load(path: &Path) -> Result<Sessions, String> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
        };
        Ok(Sessions {
            path: Some(path.to_path_buf()),
            started: text
                .lines()
                .filter_map(|l| l.split_whitespace().next())
                .map(str::to_string)
                .collect(),
        })
    }

    pub fn contains(&self, session: &str) -> bool {
        self.started.contains(session)
    }

    /// Records `session` as started, on the disk first: a start that
    /// cannot be recorded is not obeyed.
    pub fn record(&mut self, session: &str, identity: &str) -> Result<(), String> {
        if let Some(path) = &self.path {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .and_then(|mut f| {
                    writeln!(f, "{session} {identity}")?;
                    Ok(f)
                })
                .map_err(|e| format!("cannot record the session in {}: {e}", path.display()))?;
            f.flush()
                .and_then(|()| f.sync_all())
                .map_err(|e| format!("cannot record the session in {}: {e}", path.display()))?;
        }
        self.started.insert(session.to_string());
        Ok(())
    }
}

/// A deploy session id as the ground station makes them: 32 hex digits.
/// Anything else is refused before it is compared or written down.
pub(crate) fn check_session(session: &str) -> Result<(), String> {
    if session.len() == 32 && session.bytes().all(|b| b.is_ascii_hexdigit()) {
        Ok(())
    } else {
        Err(format!(
            "malformed deploy session `{}`: a session is 32 hex digits",
            session.escape_debug()
        ))
    }
}

/// A fresh deploy session id.
pub fn new_session() -> String {
    format!("{:032x}", rand::random::<u128>())
}
