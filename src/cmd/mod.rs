//! One module per subcommand. Each returns the process exit status:
//! 0 success, 1 findings (where a command has findings), 2 bad input.

pub mod abort;
pub mod agent;
pub mod bench_report;
pub mod build;
pub mod check;
pub mod deploy;
pub mod gen;
pub mod keygen;
pub mod live;
pub mod lsp;
pub mod mission;
pub mod monitor;
pub mod plan;
pub mod router;
pub mod run;
pub mod sim_vehicle;
pub mod slices;
pub mod view;

/// How long a command's runtime waits, once the command is done, for the
/// tasks still running in it (zenoh closing its links) before it ends.
const TEARDOWN: std::time::Duration = std::time::Duration::from_secs(2);

/// The async runtime of a command that joins zenoh, which never holds up
/// the command's end for more than [`TEARDOWN`].
///
/// Why: a ground station that routes for a hundred drones (see
/// `eamos_fleet::Fleet::hub`) sees them all close their links as the
/// mission ends, and zenoh's links in low-latency mode then sometimes
/// block on each other inside the runtime. Dropping a tokio runtime waits
/// for its blocked tasks without limit, so the process, its mission done
/// and its report printed, never ended. By then every log is written and
/// every journal entry on the disk: what is left to wait for is only the
/// links' goodbyes.
pub struct Runtime(Option<tokio::runtime::Runtime>);

impl Runtime {
    pub fn new() -> std::io::Result<Runtime> {
        tokio::runtime::Builder::new_multi_thread()
            .enable_all()
            .build()
            .map(|r| Runtime(Some(r)))
    }

    pub fn block_on<F: std::future::Future>(&self, future: F) -> F::Output {
        self.0
            .as_ref()
            .expect("the runtime is only taken when dropped")
            .block_on(future)
    }
}

impl Drop for Runtime {
    fn drop(&mut self) {
        if let Some(r) = self.0.take() {
            r.shutdown_timeout(TEARDOWN);
        }
    }
}
