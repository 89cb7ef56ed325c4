//! Runs the Python package's pytest suite (`test_flexshape.py`) against the extension module
//! this build made: the module and the package's Python files are put together in a temporary
//! folder, and pytest runs in a virtual environment with NumPy (made once under the target
//! folder, `python-test-env`; pip fetches NumPy and pytest from PyPI the first time).
//!
//! Without Python 3 the test says so and passes, unless `FLEXSHAPE_REQUIRE_PYTHON=1` (as in
//! CI), which makes a missing interpreter or a failed environment a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The interpreter to build the environment from: `FLEXSHAPE_PYTHON`, else `python3`.
fn python() -> String {
    std::env::var("FLEXSHAPE_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn required() -> bool {
    std::env::var("FLEXSHAPE_REQUIRE_PYTHON").is_ok_and(|v| v == "1")
}

/// Runs `command`; its combined output when it fails.
fn run(command: &mut Command) -> Result<String, String> {
    let out = command
        .output()
        .map_err(|e| format!("cannot run {command:?}: {e}"))?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if out.status.success() {
        Ok(text)
    } else {
        Err(format!("{command:?} failed ({}):\n{text}", out.status))
    }
}

/// The virtual environment with NumPy and pytest, made once under `target`.
fn environment(target: &Path) -> Result<PathBuf, String> {
    let env = target.join("python-test-env");
    let bin = env.join("bin").join("python");
    let ready = |bin: &Path| {
        Command::new(bin)
            .args(["-c", "import numpy, pytest"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !ready(&bin) {
        run(Command::new(python())
            .args(["-m", "venv", "--clear"])
            .arg(&env))?;
        run(Command::new(&bin).args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "numpy",
            "pytest",
        ]))?;
    }
    Ok(bin)
}

#[test]
fn the_python_package_passes_its_pytest_suite() {
    // This test's executable is target/PROFILE/deps/pytest-HASH; the module is built beside.
    let exe = std::env::current_exe().expect("the test's own path");
    let deps = exe.parent().expect("the deps folder");
    let profile = deps.parent().expect("the profile folder");
    let module = ["lib_flexshape.so", "lib_flexshape.dylib", "_flexshape.dll"]
        .iter()
        .map(|name| deps.join(name))
        .find(|p| p.is_file())
        .or_else(|| Some(profile.join("lib_flexshape.so")).filter(|p| p.is_file()))
        .expect("the extension module is built before its tests (the package's cdylib)");
    let python_ok = Command::new(python()).arg("--version").output().is_ok();
    if !python_ok {
        assert!(
            !required(),
            "FLEXSHAPE_REQUIRE_PYTHON=1 but `{}` does not run",
            python()
        );
        eprintln!(
            "skipped: no Python 3 (`{}`); set FLEXSHAPE_PYTHON to one",
            python()
        );
        return;
    }
    let bin = match environment(profile.parent().unwrap_or(profile)) {
        Ok(bin) => bin,
        Err(e) if !required() => {
            eprintln!("skipped: no environment with NumPy and pytest: {e}");
            return;
        }
        Err(e) => panic!("{e}"),
    };
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("a temporary folder");
    let package = dir.path().join("flexshape");
    std::fs::create_dir(&package).expect("the package folder");
    for entry in std::fs::read_dir(here.join("python/flexshape")).expect("python/flexshape") {
        let path = entry.expect("a package file").path();
        if path.is_file() {
            std::fs::copy(&path, package.join(path.file_name().expect("a name")))
                .expect("a copy of the package file");
        }
    }
    std::fs::copy(&module, package.join("_flexshape.abi3.so")).expect("a copy of the module");
    let output = run(Command::new(&bin)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-rA"])
        .arg(here.join("tests/test_flexshape.py"))
        .env("PYTHONPATH", dir.path())
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .current_dir(dir.path()));
    match output {
        Ok(text) => println!("{text}"),
        Err(e) => panic!("{e}"),
    }
}
