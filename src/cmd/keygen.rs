//! `eamos keygen`: writes the ground station's key pair. The secret key
//! (`gcs.key`) stays on the ground station and signs every slice and
//! command `eamos deploy` sends; the public key (`gcs.pub`) goes beside the
//! fleet file on every companion computer, named by `[keys] gcs`, and the
//! agents then refuse whatever it did not sign. Exit status: 0 written,
//! 2 bad input (an existing key is never overwritten).

use std::path::PathBuf;
use std::process::ExitCode;

use eamos_seal::{pair_paths, GroundKey};

/// Write a ground-station key pair (ed25519, PEM): NAME.key and NAME.pub.
#[derive(clap::Args)]
pub struct Args {
    /// The directory to write the pair in.
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub out: PathBuf,
    /// The files' name: NAME.key (secret) and NAME.pub (public).
    #[arg(long, value_name = "NAME", default_value = "gcs")]
    pub name: String,
}

pub fn run(args: Args) -> ExitCode {
    let (secret, public) = pair_paths(&args.out, &args.name);
    let written = GroundKey::generate().and_then(|k| {
        k.write_pair(&secret, &public)?;
        Ok(k.public().fingerprint())
    });
    match written {
        Ok(fingerprint) => {
            println!(
                "secret key: {} (keep it on the ground station)",
                secret.display()
            );
            println!("public key: {} ({fingerprint})", public.display());
            println!(
                "name the public key in the fleet file, relative to it:\n\n[keys]\ngcs = \"{}.pub\"",
                args.name
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
