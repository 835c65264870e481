//! One two-view demo for every test that needs a simulated, fully processed scan. Simulating and
//! processing it takes about 18 s in the test profile; four tests used to make their own. Each test
//! takes a copy, so what one changes no other sees.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

/// The demo's folder (`scan/`, `processed/`, `accuracy.json`) and what `demo` printed.
struct Demo {
    dir: PathBuf,
    stdout: String,
}

static DEMO: OnceLock<Demo> = OnceLock::new();

fn demo() -> &'static Demo {
    DEMO.get_or_init(|| {
        // Under Cargo's scratch folder for integration tests, one per test process: a demo from an
        // earlier build is never taken for this one's.
        let scratch = Path::new(env!("CARGO_TARGET_TMPDIR"));
        remove_stale(scratch);
        let dir = scratch.join(format!("shared-demo-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let o: Output = crate::run::scanrig(&[&"demo", &"--views", &"2", &"--out", &dir]);
        assert!(o.status.success(), "the shared demo failed: {}", String::from_utf8_lossy(&o.stderr));
        Demo { dir, stdout: String::from_utf8_lossy(&o.stdout).into_owned() }
    })
}

/// Removes the demos of test processes that have ended (statics are never dropped, so each process
/// leaves its demo behind).
fn remove_stale(scratch: &Path) {
    let Ok(entries) = std::fs::read_dir(scratch) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if let Some(pid) = name.strip_prefix("shared-demo-")
            && !Path::new("/proc").join(pid).exists()
        {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// What `scanrig demo --views 2` printed.
pub fn demo_stdout() -> &'static str {
    &demo().stdout
}

/// A private copy of the processed two-view demo in `dest` (made if needed): returns `dest/demo`.
pub fn copy_demo(dest: &Path) -> PathBuf {
    let out = dest.join("demo");
    copy_tree(&demo().dir, &out);
    out
}

/// A copy of the folder `from` (and everything under it) at `to`.
pub fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}
