//! `eamos sim-vehicle`: a simulated copter behind a MAVLink 2 endpoint that
//! behaves like an ArduPilot copter, or with `--autopilot px4` like PX4
//! (see the `eamos-vehicle` crate), for trying a fleet file, a ground
//! station or a script without SITL.
//!
//! By default it talks like SITL started with `--out`: from a port of its
//! own to a ground station listening on `udpin:127.0.0.1:14550`. It runs
//! until interrupted (or `--exit-after`). Exit status: 0 when it stopped as
//! asked, 2 bad input.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::time::Duration;

use eamos_geo::Wgs84;
use eamos_mid::mavlink::ConnectAddress;
use eamos_vehicle::{Firmware, SimVehicle, SimVehicleOptions};

/// Whose behaviour the vehicle imitates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Autopilot {
    /// An ArduPilot copter: GUIDED, streams only when asked.
    Ardupilot,
    /// PX4: OFFBOARD only with a setpoint stream, left when it stops.
    Px4,
}

/// Fly a simulated copter over MAVLink, like an ArduPilot or PX4 SITL copter.
#[derive(clap::Args)]
pub struct Args {
    /// The autopilot it behaves like.
    #[arg(long, value_enum, default_value_t = Autopilot::Ardupilot)]
    pub autopilot: Autopilot,
    /// PX4: simulated seconds without an OFFBOARD setpoint after which
    /// OFFBOARD is refused, or left for AUTO.LOITER (PX4's COM_OF_LOSS_T).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0)]
    pub offboard_loss_after: f64,
    /// Where it talks: `udpout:HOST:PORT` (to a listening ground station,
    /// like SITL's `--out`), `udpin:HOST:PORT` or `tcpin:HOST:PORT` (it
    /// listens, like SITL's `tcp:5760`).
    #[arg(long, value_name = "ADDRESS", default_value = "udpout:127.0.0.1:14550")]
    pub connect: String,
    /// Its MAVLink system id.
    #[arg(long, value_name = "ID", default_value_t = 1)]
    pub sysid: u8,
    /// Simulated seconds from boot until it is ready to arm (GPS fix, EKF
    /// origin, EKF using GPS and pre-arm checks come in stages, as in SITL).
    #[arg(long, value_name = "SECONDS", default_value_t = 40.0)]
    pub ready_after: f64,
    /// Simulated seconds per real second.
    #[arg(long, value_name = "N", default_value_t = 1.0)]
    pub speed: f64,
    /// Where it stands at boot: latitude, longitude (degrees), altitude
    /// (metres above sea level).
    #[arg(
        long,
        value_name = "LAT,LON,ALT",
        default_value = "-35.363261,149.165230,584",
        allow_hyphen_values = true
    )]
    pub home: String,
    /// Simulated seconds after boot at which the RC mode switch selects
    /// STABILIZE, overwriting a mode set before (ArduPilot reads the switch
    /// about 2 s after boot).
    #[arg(long, value_name = "SECONDS")]
    pub rc_mode_switch_at: Option<f64>,
    /// Refuse arming with this message although the pre-arm checks pass
    /// (an arming check such as "Arm: Hardware safety switch").
    #[arg(long, value_name = "TEXT")]
    pub refuse_arming: Option<String>,
    /// Simulated seconds armed on the ground without a take-off before it
    /// disarms itself (ArduPilot's DISARM_DELAY).
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub idle_disarm_after: f64,
    /// Set a parameter the vehicle acts on, as on the autopilot
    /// (`FS_GCS_ENABLE=1`, `FS_GCS_TIMEOUT=3`; PX4 `COM_OBL_RC_ACT=4`);
    /// repeat for several.
    #[arg(long = "param", value_name = "NAME=VALUE", value_parser = parse_param)]
    pub params: Vec<(String, f64)>,
    /// How far (m) the reported position of a flying copter wanders, as a
    /// real EKF's estimate does while hovering (0: none).
    #[arg(long, value_name = "METRES", default_value_t = 0.05)]
    pub position_noise: f64,
    /// Stop after this many real seconds (for scripts and tests).
    #[arg(long, value_name = "SECONDS")]
    pub exit_after: Option<f64>,
}

fn parse_param(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not NAME=VALUE"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`{value}` is not a number"))?;
    Ok((name.trim().to_string(), value))
}

fn bad_input(message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    let connect = match ConnectAddress::parse(&args.connect) {
        Ok(ConnectAddress::TcpOut(_)) => {
            return bad_input(
                "--connect: the vehicle listens or sends to a ground station: use udpout:, udpin: or tcpin:",
            )
        }
        Ok(a) => a,
        Err(e) => return bad_input(&format!("--connect: {e}")),
    };
    let home = match Wgs84::parse(&args.home) {
        Ok(h) => h,
        Err(e) => return bad_input(&format!("--home: {e}")),
    };
    if let Some(t) = args.exit_after {
        if !(t.is_finite() && t > 0.0) {
            return bad_input(&format!(
                "--exit-after must be a number of seconds above zero, not {t}"
            ));
        }
    }
    let options = SimVehicleOptions {
        connect,
        system_id: args.sysid,
        ready_after: args.ready_after,
        speed: args.speed,
        home,
        rc_mode_switch_at: args.rc_mode_switch_at,
        refuse_arming: args.refuse_arming,
        idle_disarm_after: args.idle_disarm_after,
        autopilot: match args.autopilot {
            Autopilot::Ardupilot => Firmware::ArduPilot,
            Autopilot::Px4 => Firmware::Px4,
        },
        offboard_loss_after: args.offboard_loss_after,
        params: args.params,
        position_noise: args.position_noise,
        ..SimVehicleOptions::default()
    };
    if let Err(e) = options.validate() {
        return bad_input(&e);
    }
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .try_init();
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the runtime: {e}")),
    };
    runtime.block_on(async move {
        let description = format!(
            "{:?} system {} on {} at {}x real time, ready after {} s, home {:.7},{:.7},{}",
            options.autopilot,
            options.system_id,
            options.connect,
            options.speed,
            options.ready_after,
            options.home.lat,
            options.home.lon,
            options.home.alt
        );
        let vehicle = match SimVehicle::start(options).await {
            Ok(v) => v,
            Err(e) => return bad_input(&e),
        };
        eprintln!("sim-vehicle: {description}");
        if let Some(local) = vehicle.local_addr() {
            eprintln!("sim-vehicle: listening on {local}");
        }
        let limit = async {
            match args.exit_after {
                Some(t) => tokio::time::sleep(Duration::from_secs_f64(t)).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            _ = tokio::signal::ctrl_c() => eprintln!("sim-vehicle: interrupted"),
            _ = limit => eprintln!("sim-vehicle: --exit-after reached"),
        }
        vehicle.shutdown().await;
        ExitCode::SUCCESS
    })
}
