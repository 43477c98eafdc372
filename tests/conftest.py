import os
import pathlib
import sys

# Bytecode caches on, also where PYTHONDONTWRITEBYTECODE is set (container
# images set it): without them every worker rewrites and compiles every test
# module at collection (some 4 CPU seconds each) and every Python subprocess a
# test starts (the CLI, an emulator) compiles the package's modules again.
# The caches go to the __pycache__ folders git ignores.
# INCLINO_TEST_NO_BYTECODE=1 keeps the environment's setting.
if not os.environ.get("INCLINO_TEST_NO_BYTECODE", "").strip():
    sys.dont_write_bytecode = False
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

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

# Hypothesis profiles of the hostile-input property suites
# (tests/test_hostile_props*.py, tests/test_hostile_emu.py; docs/testing.md):
# `make test` runs each property with the module's small count; the profile
# "full" (pytest --hypothesis-profile=full) runs 10 000 generated inputs per
# property, each reader and each format its own property.
try:
    from hypothesis import HealthCheck, settings as _hsettings

    _hsettings.register_profile("full", max_examples=10_000, deadline=None, database=None,
                                suppress_health_check=list(HealthCheck))
except ImportError:  # hypothesis is a test extra: its modules skip without it
    pass


def hypothesis_examples(default: int) -> int:
    """Examples per property: INCLINO_HYPOTHESIS_EXAMPLES, else the full
    profile's 10 000 under --hypothesis-profile=full, else `default`."""
    v = os.environ.get("INCLINO_HYPOTHESIS_EXAMPLES")
    if v:
        return int(v)
    from hypothesis import settings

    return settings.get_profile("full").max_examples if settings.get_current_profile_name() == "full" else default


# CI (.ci/run, CI=true) installs every tool the suite uses (sdcc, ucsim,
# cppcheck, clang-format, clang/libFuzzer, binutils-m68hc1x, cmake) and the
# test extra: there a test that skips (a tool or package missing) is a
# failure, so a package that stops installing cannot leave CI green.
IN_CI = os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _skip_reason(longrepr) -> str:
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2])
    return str(longrepr)


def test_seed() -> int:
    """The seed of a test's random draws: INCLINO_TEST_SEED when set (to
    replay a failure), else drawn now."""
    env = os.environ.get("INCLINO_TEST_SEED", "").strip()
    return int(env) if env else int.from_bytes(os.urandom(4), "little")


test_seed.__test__ = False  # a helper, not a test


@pytest.fixture
def rng(request):
    """A NumPy generator for a test's random draws, with its seed recorded:
    INCLINO_TEST_SEED when set (to replay a failure), else drawn now.  A
    failing test's report names the seed, and every test's seed is among
    its user properties (--junitxml)."""
    import numpy as np

    seed = test_seed()
    request.node.inclino_seed = seed
    request.node.user_properties.append(("seed", seed))
    return np.random.default_rng(seed)


@pytest.fixture(scope="module")
def module_rng(request):
    """`rng` for a module-scoped fixture's draws (a calibration shared by
    the module's tests): its own seed, by the same rule, named in the
    report of any of the module's tests that fails."""
    import numpy as np

    seed = test_seed()
    request.node.inclino_module_seed = seed
    return np.random.default_rng(seed)


@pytest.fixture
def ctl(emu):
    """The control channel of the module's emulated probe (its `emu`
    fixture), the link's faults cleared before and after the test."""
    from inclino_emu.control import ControlClient

    c = ControlClient(port=emu.control_port)
    clear = dict(bit_error_rate=0.0, drop_rate=0.0, dup_rate=0.0, disconnected=False)
    c.call("faults", **clear)
    yield c
    c.call("faults", **clear)
    c.close()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    seed = getattr(item, "inclino_seed", None)
    if seed is not None and rep.failed:
        rep.sections.append(("random draws", f"seed {seed}: replay with INCLINO_TEST_SEED={seed}"))
    mseed = next((n.inclino_module_seed for n in item.listchain() if hasattr(n, "inclino_module_seed")), None)
    if mseed is None:  # a module's own generator at import: RNG_SEED = test_seed(); RNG = default_rng(RNG_SEED)
        mseed = getattr(getattr(item, "module", None), "RNG_SEED", None)
    if mseed is not None and rep.failed and mseed != seed:
        rep.sections.append(("random draws (module fixtures)",
                             f"seed {mseed}: replay with INCLINO_TEST_SEED={mseed}"))
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
_SHARED_SCOPES = ("module", "session", "package", "class")
# Modules whose module-scoped fixtures are cheap to build (an emulated probe starts in a fraction of a second)
# and whose tests are long: each test a unit, each worker builds the fixture it needs.
SPLIT_MODULES = {
    "tests/test_probe_cli.py",  # the power cut at every flash step, the noisy line: ~50 s on one emulator
}


# Modules whose tests share state that neither their arguments nor their source's fixtures show: one unit.
WHOLE_MODULES = {
    # test_the_makefile_stamp_covers_every_compiled_input sets fx_ops.h's mtime ahead for `make -n`;
    # test_compiled_firmware_is_not_older_than_its_sources reads the mtimes: side by side they raced
    "tests/test_build.py",
    # test_the_source_walk_sees_a_planted_write adds a module to host/inclino/formats for a moment;
    # test_no_module_writes_a_file_except_through_safeio, walking the same tree beside it, met it half-gone
    "tests/test_cli_paths.py",
}


def _module_sharing(path: pathlib.Path) -> tuple[bool, set]:
    """(whole, names) for a test module, read from its source (the
    controller of pytest-xdist schedules by node id and never imports the
    tests): `whole` when the module shares state in a way a test's
    arguments do not show (an autouse fixture of a wider scope,
    setup_module, test classes); else the names of its test functions
    that reach a module-scoped fixture of the module, directly or through
    its other fixtures."""
    import ast

    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return True, set()
    fixtures, wide = {}, set()
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and node.name.startswith("Test"):
            return True, set()
        if isinstance(node, ast.FunctionDef) and node.name in ("setup_module", "teardown_module"):
            return True, set()
        if not isinstance(node, ast.FunctionDef):
            continue
        for d in node.decorator_list:
            call = d if isinstance(d, ast.Call) else None
            target = call.func if call else d
            if ast.unparse(target) not in ("pytest.fixture", "fixture"):
                continue
            kw = {k.arg: k.value for k in (call.keywords if call else [])}
            scope = kw.get("scope")
            autouse = kw.get("autouse")
            is_wide = isinstance(scope, ast.Constant) and scope.value in _SHARED_SCOPES
            if is_wide and isinstance(autouse, ast.Constant) and autouse.value:
                return True, set()
            fixtures[node.name] = [a.arg for a in node.args.args]
            if is_wide:
                wide.add(node.name)
    def reaches(names, seen):
        for n in names:
            if n in wide:
                return True
            if n in fixtures and n not in seen and reaches(fixtures[n], seen | {n}):
                return True
        return False
    users = {node.name for node in tree.body if isinstance(node, ast.FunctionDef) and node.name.startswith("test")
             and reaches([a.arg for a in node.args.args], set())}
    return False, users


_SHARING: dict = {}


def scheduling_unit(nodeid: str) -> str:
    """The unit of work a test belongs to under `make test`: the tests that
    read one session fixture across modules (SHARED_SESSION_FIXTURE) are
    one unit; the tests of a module that reach one of its module-scoped
    fixtures (an emulated chamber run, a firmware built for the S08
    simulator) are one unit, so that the fixture is built once, on one
    worker; every other test is a unit of its own, free to run on either
    worker."""
    module, _, rest = nodeid.partition("::")
    name = rest.split("[", 1)[0].split("::")[-1]
    if name in SHARED_SESSION_FIXTURE:
        return SHARED_SESSION_FIXTURE[name]
    if module not in _SHARING:
        _SHARING[module] = _module_sharing(ROOT / module)
    whole, users = _SHARING[module]
    if module in SPLIT_MODULES:
        return nodeid
    if module in WHOLE_MODULES:
        return module
    if whole or "::" in rest or name in users:
        return module
    return nodeid


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_auto_num_workers(config):
    """-n auto: one worker more than the cores (PYTEST_XDIST_AUTO_NUM_WORKERS
    still sets the count).  A fifth of the suite's wall time on two cores
    was tests that wait -- link timeouts after a power cut, a chamber
    emulator pacing its replies, a flash's restart -- with their core idle;
    a third worker runs a computing test meanwhile, for ~7 CPU seconds of
    its own start-up and collection."""
    env = os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS", "").strip()
    if env.isdigit():
        return int(env)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # no sched_getaffinity (macOS)
        cores = os.cpu_count() or 1
    return cores + 1


@pytest.hookimpl(optionalhook=True)  # a hook of pytest-xdist: unknown (and unused) under -p no:xdist
def pytest_xdist_make_scheduler(config, log):
    """make test (-n auto --dist loadscope --no-loadscope-reorder): units of
    work as `scheduling_unit` says, handed out in the collection's order,
    which puts the longest units first (pytest_collection_modifyitems
    below), so that no long test starts last and leaves the other core
    idle at the end.  A worker is given its next unit only when it is down
    to its last test (xdist's default: two), so that the queue stays
    shared as long as it can."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return scheduling_unit(nodeid)

        def _reschedule(self, node) -> None:
            if node.shutting_down:
                return
            if not self.workqueue:
                node.shutdown()
                return
            # the worker runs a test once it knows the next one (its teardown depends on it): one pending
            # test is the one it is about to run
            if self._pending_of(self.assigned_work[node]) > 1:
                return
            self._assign_work_unit(node)

    return UnitScheduling(config, log)


# Seconds per test (setup + call + teardown, wall) of a whole `make test` run, written by
# `make test PYTEST_ARGS=--store-durations`: the scheduler hands out the longest units first.
DURATIONS = ROOT / "tests" / "durations.json"
DEFAULT_S = 0.5  # a test not in the file (added since): a short one
HEAVY_S = 30.0  # ... unless marked heavy


def pytest_addoption(parser):
    parser.addoption("--store-durations", action="store_true",
                     help=f"write each test's seconds (setup + call + teardown) to {DURATIONS.relative_to(ROOT)}")


def unit_seconds(items, durations: dict) -> dict:
    """Seconds of each scheduling unit: the sum over its tests, from
    `durations` (node id -> s), a test missing there DEFAULT_S, HEAVY_S
    when marked heavy."""
    cost: dict = {}
    for it in items:
        s = durations.get(it.nodeid)
        if s is None:
            s = HEAVY_S if it.get_closest_marker("heavy") is not None else DEFAULT_S
        u = scheduling_unit(it.nodeid)
        cost[u] = cost.get(u, 0.0) + float(s)
    return cost


def order_class(seconds: float) -> int:
    """Units within a factor of two of each other are one class (every unit
    under a second is class 0): the classes run longest first, and within
    a class pytest-randomly's shuffle stays in force."""
    import math

    return max(0, int(math.floor(math.log2(max(seconds, 1e-9)))) + 1)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    """The longest units first (tests/durations.json; a test missing there
    counts as short unless marked `heavy`), so that no long test starts last
    and leaves the other core idle at the end: a stable sort by class
    (order_class) after pytest-randomly's shuffle, which stays in force
    within each class."""
    import json

    try:
        durations = json.loads(DURATIONS.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        durations = {}
    cost = unit_seconds(items, durations)
    items.sort(key=lambda it: -order_class(cost[scheduling_unit(it.nodeid)]))


_SECONDS: dict = {}


def pytest_runtest_logreport(report):
    if report.when in ("setup", "call", "teardown"):
        _SECONDS[report.nodeid] = _SECONDS.get(report.nodeid, 0.0) + report.duration


def pytest_sessionfinish(session, exitstatus):
    """--store-durations: each test's seconds into tests/durations.json (on
    the controller, which receives every worker's reports)."""
    if not session.config.getoption("store_durations") or hasattr(session.config, "workerinput"):
        return
    import json

    DURATIONS.write_text(json.dumps({k: round(v, 2) for k, v in sorted(_SECONDS.items())}, indent=0) + "\n",
                         encoding="utf-8")


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
