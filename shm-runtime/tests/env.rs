//! `ShmContext::from_env` and `ROS_DOMAIN_ID` against the real process
//! environment. Alone in its own test binary, and one test: setting variables
//! while other threads read the environment races.

use shm_runtime::rmw::Distro;
use shm_runtime::{PoolSize, RosNode, ShmConfig, ShmContext};
use zenoh::Wait;

/// One test: the steps below set variables, and must not run beside each other.
#[test]
fn environment_variables() {
    shm_variables_enable_configure_and_reject();
    a_bad_ros_domain_id_is_refused();
    ros_distro_picks_the_conventions();
}

fn shm_variables_enable_configure_and_reject() {
    std::env::remove_var(ShmConfig::ENV_ALLOC_SIZE);
    std::env::remove_var(ShmConfig::ENV_THRESHOLD);
    assert!(ShmContext::from_env().unwrap().is_none(), "unset: SHM off");

    std::env::set_var(ShmConfig::ENV_ALLOC_SIZE, "4194304");
    let shm = ShmContext::from_env()
        .unwrap()
        .expect("setting the pool size enables SHM");
    assert_eq!(shm.config().pool_size, PoolSize::Exact(4 << 20));
    assert_eq!(shm.pool_size(), Some(4 << 20));
    assert_eq!(shm.config().threshold, 512);
    // One pool at a time: under an ordinary user's 8 MiB memory-lock limit
    // two of 4 MiB do not fit.
    drop(shm);

    std::env::set_var(ShmConfig::ENV_THRESHOLD, "2048");
    assert_eq!(
        ShmContext::from_env().unwrap().unwrap().config().threshold,
        2048
    );

    std::env::set_var(ShmConfig::ENV_THRESHOLD, "2k");
    let err = ShmContext::from_env().unwrap_err();
    assert!(
        err.to_string().contains("ZENOH_SHM_MESSAGE_SIZE_THRESHOLD"),
        "{err}"
    );

    // Values Zenoh's allocator refuses (`Error initializing Talc backend!`, `out
    // of range for ElemIndex!`) are refused first, naming the variable and range.
    std::env::remove_var(ShmConfig::ENV_THRESHOLD);
    for bad in ["1", "18446744073709551615"] {
        std::env::set_var(ShmConfig::ENV_ALLOC_SIZE, bad);
        let err = ShmContext::from_env().unwrap_err();
        let text = format!("{err:?}");
        assert!(
            text.contains("ZENOH_SHM_ALLOC_SIZE") && text.contains("4096 to 4294967296"),
            "{text}"
        );
    }
    std::env::remove_var(ShmConfig::ENV_ALLOC_SIZE);
    std::env::remove_var(ShmConfig::ENV_THRESHOLD);
}

/// `ROS_DOMAIN_ID=abc` is an error (rcl refuses it), never silently domain 0.
fn a_bad_ros_domain_id_is_refused() {
    // Set before Zenoh starts its threads.
    std::env::set_var("ROS_DOMAIN_ID", "abc");
    let session = zenoh::open(zenoh::Config::default()).wait().unwrap();
    let err = RosNode::builder(&session, "talker")
        .wait()
        .map(|_| ())
        .unwrap_err();
    assert!(err.to_string().contains("ROS_DOMAIN_ID"), "{err}");
    // Setting the domain on the builder overrides the variable.
    let node = RosNode::builder(&session, "talker")
        .domain_id(3)
        .wait()
        .unwrap();
    assert_eq!(node.info().domain_id, 3);
}

/// `ROS_DISTRO` picks the distribution, as ROS tools read it; a name this
/// crate does not know is an error naming what to set, unless the builder
/// says which.
fn ros_distro_picks_the_conventions() {
    std::env::remove_var("ROS_DOMAIN_ID");
    let session = zenoh::open(zenoh::Config::default()).wait().unwrap();
    let distro_of = |session: &zenoh::Session| {
        RosNode::builder(session, "talker")
            .wait()
            .map(|node| node.info().distro)
    };
    std::env::remove_var("ROS_DISTRO");
    assert_eq!(distro_of(&session).unwrap(), Distro::DEFAULT);
    std::env::set_var("ROS_DISTRO", "humble");
    assert_eq!(distro_of(&session).unwrap(), Distro::Humble);
    std::env::set_var("ROS_DISTRO", "iron");
    let err = distro_of(&session).unwrap_err().to_string();
    assert!(
        err.contains("ROS_DISTRO") && err.contains("humble, jazzy, kilted, lyrical, rolling"),
        "{err}"
    );
    let node = RosNode::builder(&session, "talker")
        .distro(Distro::Jazzy)
        .wait()
        .unwrap();
    assert_eq!(node.info().distro, Distro::Jazzy);
    std::env::remove_var("ROS_DISTRO");
}
