//! The ground station's keys and signatures: one job, so that every
//! component that must trust or refuse something (an agent receiving its
//! slice, a drone told to start or to abort) does it the same way.
//!
//! The ground station holds an ed25519 key pair ([`GroundKey`]); each agent
//! is configured with its public half ([`PublicKey`], named in the fleet
//! file). Whatever the ground station sends that changes what a drone does
//! travels as a [`Sealed`] envelope: a *context* (what kind of thing it is,
//! see [`CONTEXT_SLICE`], [`CONTEXT_START`], [`CONTEXT_ABORT`]), the payload
//! bytes, and a signature over both. The context is signed too, so that a
//! signed slice can never be replayed as a start or an abort command.
//!
//! [`Sealed::open`] refuses, each with its own [`SealError`]: an unsigned
//! envelope, a signature by another key than the trusted one (naming both
//! fingerprints), a payload or context altered after signing, and an
//! envelope of another context.
//!
//! # Key files
//!
//! Both halves are PEM files that OpenSSL reads and writes as well:
//!
//! - the secret key: PKCS#8 (`-----BEGIN PRIVATE KEY-----`), written with
//!   mode 0600 on Unix (`openssl genpkey -algorithm ed25519` makes one too);
//! - the public key: SubjectPublicKeyInfo (`-----BEGIN PUBLIC KEY-----`;
//!   `openssl pkey -in gcs.key -pubout` derives it).
//!
//! A key is shown by its fingerprint, `ed25519:` and the first 16 hex digits
//! of the SHA3-256 of the raw 32-byte public key.
//!
//! # Example: signing and checking an abort command
//!
//! ```
//! use eamos_seal::{GroundKey, Sealed, SealError, CONTEXT_ABORT};
//!
//! // The ground station (in the field: GroundKey::load("gcs.key")).
//! let key = GroundKey::generate().unwrap();
//! let wire = key
//!     .seal(CONTEXT_ABORT, b"abort ExperimentB-1a2b3c".to_vec())
//!     .to_bytes();
//!
//! // A drone's agent, configured with the ground station's public key
//! // (in the field: PublicKey::load("gcs.pub")).
//! let trusted = key.public();
//! let envelope = Sealed::from_bytes(&wire).unwrap();
//! let payload = envelope.open(&trusted, CONTEXT_ABORT).unwrap();
//! assert_eq!(payload, b"abort ExperimentB-1a2b3c");
//!
//! // An unsigned abort is refused, with a message saying so.
//! let forged = Sealed::unsigned(CONTEXT_ABORT, b"abort ExperimentB-1a2b3c".to_vec());
//! let refused = forged.open(&trusted, CONTEXT_ABORT).unwrap_err();
//! assert!(matches!(refused, SealError::Unsigned { .. }));
//! ```
//!
//! The payload should name the mission identity it is meant for, so that a
//! command of one mission can never act on another.

use std::fmt;
use std::path::{Path, PathBuf};

use ed25519_dalek::pkcs8::spki::der::pem::LineEnding;
use ed25519_dalek::pkcs8::{DecodePrivateKey, DecodePublicKey, EncodePrivateKey, EncodePublicKey};
use ed25519_dalek::{Signature, Signer, SigningKey, VerifyingKey};
use rand::TryRngCore;
use serde::{Deserialize, Serialize};
use sha3::{Digest, Sha3_256};

/// A mission slice sent to a drone's agent.
pub const CONTEXT_SLICE: &str = "eamos/slice";
/// The command that starts a deployed mission.
pub const CONTEXT_START: &str = "eamos/start";
/// The command that aborts a running mission.
pub const CONTEXT_ABORT: &str = "eamos/abort";

/// Bumped whenever the envelope or the signed bytes change shape: an old
/// agent then says "another format" instead of "bad signature".
const ENVELOPE_VERSION: u8 = 1;
/// Prefixed to everything signed, so that these signatures mean nothing to
/// any other protocol that might use the same key.
const DOMAIN: &[u8] = b"eamos-seal/1\0";

/// The ground station's secret key.
pub struct GroundKey {
    key: SigningKey,
}

/// The ground station's public key, as agents know it.
#[derive(Clone, PartialEq, Eq)]
pub struct PublicKey {
    key: VerifyingKey,
}

/// Why a key file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    #[error("cannot read key file {path}: {error}")]
    Read { path: String, error: String },
    #[error("{path}: not an ed25519 {expected} ({error})")]
    Parse {
        path: String,
        expected: &'static str,
        error: String,
    },
    #[error("cannot write key file {path}: {error}")]
    Write { path: String, error: String },
    #[error("cannot draw a random key from the operating system: {0}")]
    Random(String),
}

/// Why a sealed envelope is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SealError {
    #[error("not signed: this {what} carries no signature, and only ones signed by the ground station key {trusted} are accepted")]
    Unsigned { what: String, trusted: String },
    #[error("unknown key: this {what} is signed by {signer}, but only the ground station key {trusted} is trusted")]
    UnknownKey {
        what: String,
        signer: String,
        trusted: String,
    },
    #[error(
        "bad signature: this {what} was altered after it was signed (or its signature is damaged)"
    )]
    BadSignature { what: String },
    #[error("wrong kind of message: expected a signed {expected}, got a {found}")]
    WrongContext { expected: String, found: String },
    #[error("not a sealed message: {0}")]
    Malformed(String),
}

/// A payload with the context it was sent as and, if signed, the signer's
/// public key and the signature over both.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sealed {
    version: u8,
    context: String,
    payload: Vec<u8>,
    seal: Option<Seal>,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct Seal {
    signer: [u8; 32],
    signature: Vec<u8>,
}

fn signed_bytes(context: &str, payload: &[u8]) -> Vec<u8> {
    let mut m = Vec::with_capacity(DOMAIN.len() + context.len() + 1 + payload.len());
    m.extend_from_slice(DOMAIN);
    m.extend_from_slice(context.as_bytes());
    m.push(0);
    m.extend_from_slice(payload);
    m
}

/// What a context is called in messages: `eamos/slice` -> `slice`.
fn what(context: &str) -> String {
    let short = context.rsplit('/').next().unwrap_or(context);
    match short {
        "start" | "abort" => format!("{short} command"),
        _ => short.to_string(),
    }
}

impl GroundKey {
    /// A new key pair from the operating system's random source.
    pub fn generate() -> Result<GroundKey, KeyError> {
        let mut seed = [0u8; 32];
        rand::rngs::OsRng
            .try_fill_bytes(&mut seed)
            .map_err(|e| KeyError::Random(e.to_string()))?;
        Ok(GroundKey {
            key: SigningKey::from_bytes(&seed),
        })
    }

    /// Reads a PKCS#8 PEM secret key; `name` is what errors call it.
    pub fn from_pem(text: &str, name: &str) -> Result<GroundKey, KeyError> {
        SigningKey::from_pkcs8_pem(text)
            .map(|key| GroundKey { key })
            .map_err(|e| KeyError::Parse {
                path: name.to_string(),
                expected: "private key in PKCS#8 PEM (-----BEGIN PRIVATE KEY-----)",
                error: e.to_string(),
            })
    }

    pub fn load(path: &Path) -> Result<GroundKey, KeyError> {
        let text = read(path)?;
        GroundKey::from_pem(&text, &path.display().to_string())
    }

    /// The PKCS#8 PEM form of the secret key.
    pub fn to_pem(&self) -> String {
        self.key
            .to_pkcs8_pem(LineEnding::LF)
            .expect("an ed25519 key always encodes")
            .to_string()
    }

    pub fn public(&self) -> PublicKey {
        PublicKey {
            key: self.key.verifying_key(),
        }
    }

    /// Signs `payload` as a message of `context`.
    pub fn seal(&self, context: &str, payload: Vec<u8>) -> Sealed {
        let signature = self.key.sign(&signed_bytes(context, &payload));
        Sealed {
            version: ENVELOPE_VERSION,
            context: context.to_string(),
            payload,
            seal: Some(Seal {
                signer: self.key.verifying_key().to_bytes(),
                signature: signature.to_bytes().to_vec(),
            }),
        }
    }

    /// Writes the key pair: the secret key (readable by its owner only, on
    /// Unix) and the public key for the agents. Refuses to overwrite an
    /// existing secret key, which would lock every configured agent out.
    pub fn write_pair(&self, secret: &Path, public: &Path) -> Result<(), KeyError> {
        let werr = |p: &Path, e: std::io::Error| KeyError::Write {
            path: p.display().to_string(),
            error: e.to_string(),
        };
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            options.mode(0o600);
        }
        let mut f = options.open(secret).map_err(|e| werr(secret, e))?;
        std::io::Write::write_all(&mut f, self.to_pem().as_bytes()).map_err(|e| werr(secret, e))?;
        std::fs::write(public, self.public().to_pem()).map_err(|e| werr(public, e))
    }
}

impl fmt::Debug for GroundKey {
    /// Never prints the secret.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "GroundKey({})", self.public().fingerprint())
    }
}

fn read(path: &Path) -> Result<String, KeyError> {
    std::fs::read_to_string(path).map_err(|e| KeyError::Read {
        path: path.display().to_string(),
        error: e.to_string(),
    })
}

impl PublicKey {
    /// Reads a SubjectPublicKeyInfo PEM public key; `name` is what errors
    /// call it.
    pub fn from_pem(text: &str, name: &str) -> Result<PublicKey, KeyError> {
        VerifyingKey::from_public_key_pem(text)
            .map(|key| PublicKey { key })
            .map_err(|e| KeyError::Parse {
                path: name.to_string(),
                expected: "public key in PEM (-----BEGIN PUBLIC KEY-----)",
                error: e.to_string(),
            })
    }

    pub fn load(path: &Path) -> Result<PublicKey, KeyError> {
        let text = read(path)?;
        PublicKey::from_pem(&text, &path.display().to_string())
    }

    pub fn to_pem(&self) -> String {
        self.key
            .to_public_key_pem(LineEnding::LF)
            .expect("an ed25519 key always encodes")
    }

    /// How messages name this key: `ed25519:` and 16 hex digits.
    pub fn fingerprint(&self) -> String {
        fingerprint(&self.key.to_bytes())
    }
}

impl fmt::Debug for PublicKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PublicKey({})", self.fingerprint())
    }
}

fn fingerprint(raw: &[u8; 32]) -> String {
    let digest = Sha3_256::digest(raw);
    let hex: String = digest[..8].iter().map(|b| format!("{b:02x}")).collect();
    format!("ed25519:{hex}")
}

impl Sealed {
    /// An envelope without a signature: what a ground station without a
    /// key sends, accepted only by agents configured without one.
    pub fn unsigned(context: &str, payload: Vec<u8>) -> Sealed {
        Sealed {
            version: ENVELOPE_VERSION,
            context: context.to_string(),
            payload,
            seal: None,
        }
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("an envelope always serialises")
    }

    /// Never panics: bytes that are not an envelope are an error.
    pub fn from_bytes(bytes: &[u8]) -> Result<Sealed, SealError> {
        let (s, rest): (Sealed, &[u8]) =
            postcard::take_from_bytes(bytes).map_err(|e| SealError::Malformed(e.to_string()))?;
        if !rest.is_empty() {
            return Err(SealError::Malformed(format!(
                "{} bytes after the envelope",
                rest.len()
            )));
        }
        if s.version != ENVELOPE_VERSION {
            return Err(SealError::Malformed(format!(
                "envelope format {} (this build reads format {ENVELOPE_VERSION})",
                s.version
            )));
        }
        Ok(s)
    }

    pub fn context(&self) -> &str {
        &self.context
    }

    /// The fingerprint of the key that signed it, if signed.
    pub fn signer(&self) -> Option<String> {
        self.seal.as_ref().map(|s| fingerprint(&s.signer))
    }

    /// The payload, after checking that it is of `context` and signed by
    /// `trusted`.
    pub fn open(&self, trusted: &PublicKey, context: &str) -> Result<&[u8], SealError> {
        self.check_context(context)?;
        let seal = self.seal.as_ref().ok_or_else(|| SealError::Unsigned {
            what: what(&self.context),
            trusted: trusted.fingerprint(),
        })?;
        if seal.signer != trusted.key.to_bytes() {
            return Err(SealError::UnknownKey {
                what: what(&self.context),
                signer: fingerprint(&seal.signer),
                trusted: trusted.fingerprint(),
            });
        }
        self.verify(&trusted.key, seal)?;
        Ok(&self.payload)
    }

    /// The payload for a receiver that trusts no key in particular (none is
    /// configured): an unsigned envelope passes, a signed one must still
    /// carry a valid signature by the key it names, so that damage shows.
    pub fn open_untrusted(&self, context: &str) -> Result<&[u8], SealError> {
        self.check_context(context)?;
        if let Some(seal) = &self.seal {
            let key =
                VerifyingKey::from_bytes(&seal.signer).map_err(|_| SealError::BadSignature {
                    what: what(&self.context),
                })?;
            self.verify(&key, seal)?;
        }
        Ok(&self.payload)
    }

    /// [`Sealed::open`] with a key, [`Sealed::open_untrusted`] without.
    pub fn open_with(
        &self,
        trusted: Option<&PublicKey>,
        context: &str,
    ) -> Result<&[u8], SealError> {
        match trusted {
            Some(k) => self.open(k, context),
            None => self.open_untrusted(context),
        }
    }

    fn check_context(&self, context: &str) -> Result<(), SealError> {
        if self.context != context {
            return Err(SealError::WrongContext {
                expected: what(context),
                found: what(&self.context),
            });
        }
        Ok(())
    }

    fn verify(&self, key: &VerifyingKey, seal: &Seal) -> Result<(), SealError> {
        let bad = || SealError::BadSignature {
            what: what(&self.context),
        };
        let signature = Signature::from_slice(&seal.signature).map_err(|_| bad())?;
        key.verify_strict(&signed_bytes(&self.context, &self.payload), &signature)
            .map_err(|_| bad())
    }
}

/// Where `eamos keygen` puts a pair named `stem`: `stem.key` and
/// `stem.pub` in `dir`.
pub fn pair_paths(dir: &Path, stem: &str) -> (PathBuf, PathBuf) {
    (
        dir.join(format!("{stem}.key")),
        dir.join(format!("{stem}.pub")),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> GroundKey {
        GroundKey::generate().unwrap()
    }

    #[test]
    fn a_signed_payload_opens_with_the_signers_public_key() {
        let k = key();
        let s = k.seal(CONTEXT_SLICE, b"slice".to_vec());
        let back = Sealed::from_bytes(&s.to_bytes()).unwrap();
        assert_eq!(back.open(&k.public(), CONTEXT_SLICE).unwrap(), b"slice");
        assert_eq!(back.signer(), Some(k.public().fingerprint()));
    }

    #[test]
    fn an_altered_payload_is_a_bad_signature() {
        let k = key();
        let mut s = k.seal(CONTEXT_START, b"start M-1".to_vec());
        s.payload[6] = b'N';
        let e = s.open(&k.public(), CONTEXT_START).unwrap_err();
        assert!(matches!(e, SealError::BadSignature { .. }), "{e}");
        assert!(e.to_string().contains("altered"), "{e}");
        assert!(e.to_string().contains("start command"), "{e}");
    }

    #[test]
    fn a_damaged_signature_is_a_bad_signature() {
        let k = key();
        let mut s = k.seal(CONTEXT_SLICE, b"x".to_vec());
        s.seal.as_mut().unwrap().signature[0] ^= 1;
        assert!(matches!(
            s.open(&k.public(), CONTEXT_SLICE),
            Err(SealError::BadSignature { .. })
        ));
        s.seal.as_mut().unwrap().signature.truncate(10);
        assert!(matches!(
            s.open_untrusted(CONTEXT_SLICE),
            Err(SealError::BadSignature { .. })
        ));
    }

    #[test]
    fn a_signature_by_another_key_names_both_keys() {
        let (k, other) = (key(), key());
        let s = other.seal(CONTEXT_SLICE, b"x".to_vec());
        let e = s.open(&k.public(), CONTEXT_SLICE).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, SealError::UnknownKey { .. }));
        assert!(msg.contains(&k.public().fingerprint()), "{msg}");
        assert!(msg.contains(&other.public().fingerprint()), "{msg}");
    }

    #[test]
    fn an_unsigned_envelope_is_refused_when_a_key_is_trusted_and_passes_when_none_is() {
        let k = key();
        let s = Sealed::unsigned(CONTEXT_ABORT, b"abort".to_vec());
        let e = s.open(&k.public(), CONTEXT_ABORT).unwrap_err();
        assert!(e.to_string().starts_with("not signed"), "{e}");
        assert_eq!(s.open_with(None, CONTEXT_ABORT).unwrap(), b"abort");
    }

    #[test]
    fn a_signed_slice_cannot_pass_as_a_start_command() {
        let k = key();
        let s = k.seal(CONTEXT_SLICE, b"x".to_vec());
        let e = s.open(&k.public(), CONTEXT_START).unwrap_err();
        assert_eq!(
            e,
            SealError::WrongContext {
                expected: "start command".into(),
                found: "slice".into()
            }
        );
        // Relabelling the context breaks the signature.
        let mut relabelled = s.clone();
        relabelled.context = CONTEXT_START.to_string();
        assert!(matches!(
            relabelled.open(&k.public(), CONTEXT_START),
            Err(SealError::BadSignature { .. })
        ));
    }

    #[test]
    fn bytes_that_are_not_an_envelope_are_an_error_not_a_panic() {
        for bytes in [&[][..], &[1, 2, 3], &[0xff; 40]] {
            assert!(matches!(
                Sealed::from_bytes(bytes),
                Err(SealError::Malformed(_))
            ));
        }
        let mut b = Sealed::unsigned(CONTEXT_SLICE, vec![]).to_bytes();
        b.push(0);
        assert!(Sealed::from_bytes(&b).is_err());
        b.pop();
        b[0] = 9;
        let e = Sealed::from_bytes(&b).unwrap_err();
        assert!(e.to_string().contains("format 9"), "{e}");
    }

    #[test]
    fn key_files_round_trip_through_pem() {
        let dir = tempfile::tempdir().unwrap();
        let k = key();
        let (secret, public) = pair_paths(dir.path(), "gcs");
        k.write_pair(&secret, &public).unwrap();
        let k2 = GroundKey::load(&secret).unwrap();
        let p = PublicKey::load(&public).unwrap();
        assert_eq!(k2.public(), k.public());
        assert_eq!(p, k.public());
        assert!(std::fs::read_to_string(&secret)
            .unwrap()
            .starts_with("-----BEGIN PRIVATE KEY-----"));
        assert!(std::fs::read_to_string(&public)
            .unwrap()
            .starts_with("-----BEGIN PUBLIC KEY-----"));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&secret).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o600);
        }
        assert!(!format!("{k2:?}").contains("PRIVATE"));
    }

    #[test]
    fn an_existing_secret_key_is_never_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let (secret, public) = pair_paths(dir.path(), "gcs");
        key().write_pair(&secret, &public).unwrap();
        let before = std::fs::read(&secret).unwrap();
        let e = key().write_pair(&secret, &public).unwrap_err();
        assert!(matches!(e, KeyError::Write { .. }), "{e}");
        assert_eq!(std::fs::read(&secret).unwrap(), before);
    }

    #[test]
    fn a_public_key_given_as_the_secret_key_is_named_for_what_it_is_not() {
        let dir = tempfile::tempdir().unwrap();
        let (secret, public) = pair_paths(dir.path(), "gcs");
        key().write_pair(&secret, &public).unwrap();
        let e = GroundKey::load(&public).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("gcs.pub") && msg.contains("BEGIN PRIVATE KEY"),
            "{msg}"
        );
        let e = PublicKey::load(&dir.path().join("missing.pub")).unwrap_err();
        assert!(matches!(e, KeyError::Read { .. }));
        assert!(PublicKey::from_pem("garbage", "x.pub").is_err());
    }
}
