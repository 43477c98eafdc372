import os
import pathlib
import sys

# One BLAS thread per test process: in every subprocess a test starts (the
# variables, read when OpenBLAS loads) and in this one (threadpoolctl: NumPy is
# already loaded by the plugins). The fits work on matrices of tens of
# columns: OpenBLAS's worker threads only contend for them, and with the suite
# on both cores (pytest-xdist) or on a loaded machine they made the
# calibration fits ten times slower (as in inclino.diagnose._blas).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# The tools installed into the virtual environment (cmake from the test extra)
# are found as on an activated environment, also when the interpreter is
# called by its path (make test: .venv/bin/python -m pytest).
_BIN = os.path.dirname(sys.executable)
if _BIN not in os.environ.get("PATH", "").split(os.pathsep):
    os.environ["PATH"] = _BIN + os.pathsep + os.environ.get("PATH", "")

import pytest
from threadpoolctl import threadpool_limits

_BLAS_LIMIT = threadpool_limits(1, "blas")

ROOT = pathlib.Path(__file__).resolve().parents[1]

# CI (.ci/run, CI=true) installs every tool the suite uses (sdcc, ucsim,
# cppcheck, clang-format, clang/libFuzzer, binutils-m68hc1x, cmake) and the
# test extra: there a test that skips (a tool or package missing) is a
# failure, so a package that stops installing cannot leave CI green.
IN_CI = os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _skip_reason(longrepr) -> str:
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2])
    return str(longrepr)


@pytest.fixture
def rng(request):
    """A NumPy generator for a test's random draws, with its seed recorded:
    INCLINO_TEST_SEED when set (to replay a failure), else drawn now.  A
    failing test's report names the seed, and every test's seed is among
    its user properties (--junitxml)."""
    import numpy as np

    env = os.environ.get("INCLINO_TEST_SEED", "").strip()
    seed = int(env) if env else int.from_bytes(os.urandom(4), "little")
    request.node.inclino_seed = seed
    request.node.user_properties.append(("seed", seed))
    return np.random.default_rng(seed)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    seed = getattr(item, "inclino_seed", None)
    if seed is not None and rep.failed:
        rep.sections.append(("random draws", f"seed {seed}: replay with INCLINO_TEST_SEED={seed}"))
    if IN_CI and rep.skipped and not hasattr(rep, "wasxfail"):
        rep.outcome = "failed"
        rep.longrepr = f"skipped under CI (CI is set: every tool is installed there): {_skip_reason(rep.longrepr)}"


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    rep = outcome.get_result()
    if IN_CI and rep.skipped:  # a module skipped as a whole (pytest.skip(allow_module_level=True))
        rep.outcome = "failed"
        rep.longrepr = f"skipped under CI (CI is set: every tool is installed there): {_skip_reason(rep.longrepr)}"


def _shares_a_module_fixture(item) -> bool:
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return False
    for defs in info.name2fixturedefs.values():
        for fd in defs:
            if fd.scope in ("module", "class", "package") and fd.baseid.startswith(item.nodeid.split("::")[0]):
                return True
    return False


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Spread over the cores (make test: pytest-xdist, --dist loadgroup):
    the tests of a module that share a module-scoped fixture (an emulated
    run, a built firmware) go to one worker, so that the fixture is built
    once; every other test is scheduled on its own.  Tests marked `heavy`
    are handed out first (after pytest-randomly's shuffle, which stays in
    force among them and among the rest), so that no long test starts last
    and leaves one core idle at the end."""
    for item in items:
        if _shares_a_module_fixture(item) and item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
    items.sort(key=lambda it: it.get_closest_marker("heavy") is None)


def pytest_terminal_summary(terminalreporter, config):
    seed = getattr(config.option, "randomly_seed", None)
    if seed is not None and config.pluginmanager.hasplugin("randomly"):
        terminalreporter.write_line(f"tests ran in random order: replay it with -p randomly --randomly-seed={seed}")


@pytest.fixture
def root():
    return ROOT


@pytest.fixture(scope="session")
def small_calibration_bench():
    """`inclino bench calibration` at its smallest (one seeded run per method,
    one temperature probe, no peer): about 30 CPU seconds, read by the
    library's test (test_calib_cli) and the command's (test_acquire_accept).
    Both carry xdist_group("calibration_bench"): built once, on one worker."""
    from inclino.benchmarks import calibration as bench

    return bench.bench_calibration(n_runs=1, include_peer=False, temperature_probes=1)
