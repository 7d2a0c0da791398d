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
pub mod slices;
pub mod sim_vehicle;
pub mod view;
