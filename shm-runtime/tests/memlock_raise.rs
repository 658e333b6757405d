//! The soft memory-lock limit is raised to the hard one when a pool is made,
//! unless the configuration says not to. Alone in its binary: the raise
//! happens once per process. `.ci/unprivileged` runs it with a soft limit
//! below the hard one; where they are equal there is nothing to raise.

use shm_runtime::{ShmConfig, ShmContext};

#[test]
fn the_soft_limit_is_raised_to_the_hard_one_unless_asked_not_to() {
    let memlock = rlimit::Resource::MEMLOCK;
    let (soft, hard) = rlimit::getrlimit(memlock).unwrap();
    if soft == hard {
        println!("soft and hard memory-lock limits are equal ({soft}): nothing to raise");
        return;
    }
    let kept = ShmContext::new(
        ShmConfig::enabled()
            .raise_memlock_limit(false)
            .pool_size_at_most(1 << 20),
    )
    .unwrap();
    assert_eq!(rlimit::getrlimit(memlock).unwrap(), (soft, hard));
    drop(kept);
    let raised = ShmContext::new(ShmConfig::enabled().pool_size_at_most(1 << 20)).unwrap();
    assert_eq!(rlimit::getrlimit(memlock).unwrap(), (hard, hard));
    assert_eq!(
        raised.memlock().limit,
        Some(hard).filter(|&h| h != rlimit::INFINITY)
    );
}
