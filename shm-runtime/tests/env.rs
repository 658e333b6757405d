//! `ShmContext::from_env` against the real process environment. Alone in its own
//! test binary: setting variables while other threads read the environment races.

use shm_runtime::{ShmConfig, ShmContext};

#[test]
fn environment_variables_enable_configure_and_reject() {
    std::env::remove_var(ShmConfig::ENV_ALLOC_SIZE);
    std::env::remove_var(ShmConfig::ENV_THRESHOLD);
    assert!(ShmContext::from_env().unwrap().is_none(), "unset: SHM off");

    std::env::set_var(ShmConfig::ENV_ALLOC_SIZE, "4194304");
    let shm = ShmContext::from_env()
        .unwrap()
        .expect("setting the pool size enables SHM");
    assert_eq!(shm.config().pool_size, 4 << 20);
    assert_eq!(shm.config().threshold, 512);

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
