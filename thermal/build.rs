//! Which opt-in tests can run here, decided when the tests are compiled, so that a test that
//! cannot run shows as ignored with its reason, never as passed: `system_tests`
//! (`WAAMTWIN_SYSTEM_TESTS=1`), the GPU's tests, which CI runs on Mesa's software Vulkan.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(system_tests)");
    println!("cargo::rerun-if-env-changed=WAAMTWIN_SYSTEM_TESTS");
    if std::env::var("WAAMTWIN_SYSTEM_TESTS").as_deref() == Ok("1") {
        println!("cargo::rustc-cfg=system_tests");
    }
}
