//! `shm-ros2 router`: a Zenoh router configured as rmw_zenoh_cpp's
//! `rmw_zenohd`, so that a system without ROS has the topology ROS users
//! have (nodes are peers that find each other through the router).

use std::sync::atomic::Ordering;
use std::time::Duration;

use shm_runtime::rmw;
use zenoh::Wait;

use crate::Error;

#[derive(Debug, clap::Args)]
pub(crate) struct RouterArgs {
    /// A Zenoh router configuration file (JSON5) to start from, as
    /// rmw_zenohd's `ZENOH_ROUTER_CONFIG_URI`; `ZENOH_CONFIG_OVERRIDE`
    /// applies on top. Default: rmw_zenohd's (tcp/[::]:7447).
    #[arg(long, env = "ZENOH_ROUTER_CONFIG_URI")]
    config: Option<std::path::PathBuf>,
    /// Endpoints to listen on, in place of the configuration's (repeatable).
    #[arg(long)]
    listen: Vec<String>,
}

pub(crate) fn run(args: &RouterArgs) -> Result<(), Error> {
    let mut config = rmw::config::router_config_from(args.config.as_deref())?;
    if !args.listen.is_empty() {
        let endpoints = serde_json::to_string(&args.listen)?;
        config
            .insert_json5("listen/endpoints", &endpoints)
            .map_err(|e| crate::context::endpoints_error("--listen", &args.listen, &e))?;
    }
    let listen = config
        .get_json("listen/endpoints")
        .unwrap_or_else(|_| "[]".to_owned());
    let stop = crate::interrupted()?;
    let session = zenoh::open(config).wait().map_err(|e| {
        format!(
            "cannot start the router (listening on {listen}): {}",
            rmw::config::zenoh_reason(&e)
        )
    })?;
    let locators: Vec<String> = session
        .info()
        .locators()
        .wait()
        .iter()
        .map(ToString::to_string)
        .collect();
    println!(
        "Zenoh router {} listening on {}; Ctrl-C stops it",
        session.zid(),
        locators.join(", ")
    );
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
    }
    session
        .close()
        .wait()
        .map_err(|e| format!("closing the router: {e}"))?;
    Ok(())
}
