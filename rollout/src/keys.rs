//! The ground station's keys as the fleet file names them: the public key
//! agents trust, and the secret key `eamos deploy` and `eamos abort` sign
//! with.

use std::path::Path;

use eamos_fleet::Fleet;
use eamos_seal::{GroundKey, PublicKey};

/// The ground station's public key named by the fleet file (its path
/// resolved when the file was read).
pub fn trusted_key(fleet: &Fleet) -> Result<Option<PublicKey>, String> {
    let Some(path) = &fleet.keys.gcs else {
        return Ok(None);
    };
    PublicKey::load(path)
        .map(Some)
        .map_err(|e| format!("[keys] gcs: {e}"))
}

/// The ground station's secret key: `explicit` (a `--key` option), or the
/// sibling with the extension `.key` of the public key the fleet names.
/// A fleet that names a public key needs the matching secret key, or every
/// agent would refuse what the ground station sends: that is an error
/// here, before anything is sent.
pub fn ground_key(fleet: &Fleet, explicit: Option<&Path>) -> Result<Option<GroundKey>, String> {
    let path = match (explicit, &fleet.keys.gcs) {
        (Some(k), _) => k.to_path_buf(),
        (None, Some(public)) => public.with_extension("key"),
        (None, None) => return Ok(None),
    };
    let key = GroundKey::load(&path).map_err(|e| e.to_string())?;
    if let Some(trusted) = trusted_key(fleet)? {
        if trusted != key.public() {
            return Err(format!(
                "{} is the secret key of {}, but the fleet file trusts {}: the agents would refuse whatever it signs",
                path.display(),
                key.public().fingerprint(),
                trusted.fingerprint()
            ));
        }
    }
    Ok(Some(key))
}
