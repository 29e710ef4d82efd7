//! Test support shared by the property-test files.

use proptest::prelude::ProptestConfig;
use proptest::test_runner::RngSeed;

/// 24 cases per property from a fixed seed (reproducible runs); `HH_CASES`
/// and `HH_SEED` in the environment override them for longer local runs. No
/// regression files are written into the source tree. `default_seed` keeps
/// each test file on its own stream of cases.
pub fn proptest_config(default_seed: u64) -> ProptestConfig {
    fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
        std::env::var(name).ok().and_then(|v| v.parse().ok())
    }
    ProptestConfig {
        cases: env("HH_CASES").unwrap_or(24),
        rng_seed: RngSeed::Fixed(env("HH_SEED").unwrap_or(default_seed)),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}
