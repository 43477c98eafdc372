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


# Tests in different modules that read one session fixture: one scheduling unit
# (one worker builds the fixture). Keyed by the test function's name.
SHARED_SESSION_FIXTURE = {
    "test_bench_calibration_small": "small_calibration_bench",  # test_calib_cli
    "test_bench_calibration_cli": "small_calibration_bench",  # test_acquire_accept
}


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist: unknown (and unused) under -p no:xdist
def pytest_xdist_make_scheduler(config, log):
    """make test (-n auto --dist loadscope --no-loadscope-reorder): every
    module is one unit of work, so that a module-scoped fixture (an emulated
    chamber run, a firmware built for the S08 simulator) is built once, on
    one worker, and the tests that share a session fixture across modules
    (SHARED_SESSION_FIXTURE) are one unit too.  Units are handed out in the
    collection's order, which puts the modules with `heavy` tests first
    (pytest_collection_modifyitems below), so that no long module starts
    last and leaves the other core idle at the end."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module, _, rest = nodeid.partition("::")
            name = rest.split("[", 1)[0].split("::")[-1]
            return SHARED_SESSION_FIXTURE.get(name, module)

    return ModuleScheduling(config, log)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """`heavy` tests first (a stable sort after pytest-randomly's shuffle,
    which stays in force among them and among the rest)."""
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
    one temperature probe, no peer, not the bench-time section): about 30 CPU seconds, read by the
    library's test (test_calib_cli) and the command's (test_acquire_accept),
    scheduled together (SHARED_SESSION_FIXTURE): built once, on one worker."""
    from inclino.benchmarks import calibration as bench

    return bench.bench_calibration(n_runs=1, include_peer=False, temperature_probes=1, time_probes=0)
