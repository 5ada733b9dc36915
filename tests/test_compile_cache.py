"""Where compiled machine code is cached (:mod:`convimpact.compiled`), the message of a cold
compile, and the kernels run as plain Python (``NUMBA_DISABLE_JIT=1``).

The compiling tests run in fresh subprocesses, each on its own temporary cache, so they never
read or write the user's cache nor the package folder.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import convimpact
from convimpact import compiled

pytest.importorskip("numba")

PACKAGE = Path(convimpact.__file__).resolve().parent
MESSAGE = "convimpact: compiling the "

# a single-contact resolve_impact (planar, default law) and a resolve_impacts batch, twice
# each; prints the cache folder and the cache files of every compiled function it used
CALLS = textwrap.dedent("""
    import json, sys
    import numpy as np
    import convimpact as ci
    from convimpact import compiled
    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    Jc = np.array([[0.0, 1.0], [1.0, 0.0]])
    dq = np.array([0.5, -1.0])
    for _ in range(2):
        r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3)
        b = ci.resolve_impacts(np.array([M] * 3), np.array([Jc] * 3), np.array([dq] * 3),
                               0.5, 0.3)
    assert np.allclose(b.impulse, r.impulse, rtol=1e-10, atol=1e-12)
    from numba.core.registry import CPUDispatcher
    used = []
    for name, mod in list(sys.modules.items()):
        if name.startswith("convimpact") and mod is not None:
            for v in list(vars(mod).values()):
                if isinstance(v, CPUDispatcher) and v.signatures:
                    used.append((v._cache.cache_path, v._cache._impl.filename_base))
    print(json.dumps({"dir": compiled._DIR, "impulse": r.impulse.tolist(), "used": used}))
""")


def _env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_DISABLE_JIT", "NUMBA_CACHE_DIR", compiled.ENV)}
    env["OPENBLAS_NUM_THREADS"] = "1"
    env.update(extra)
    return env


def _run(code: str, env: dict, timeout: float = 1200.0) -> subprocess.CompletedProcess:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=timeout)
    assert res.returncode == 0, res.stderr[-3000:]
    return res


def _package_cache_files() -> dict[str, int]:
    """numba cache files in the package folder, with their modification times."""
    out = {}
    for pattern in ("*.nbi", "*.nbc"):
        for p in PACKAGE.rglob(pattern):
            try:
                out[str(p)] = p.stat().st_mtime_ns
            except OSError:
                pass
    return out


@pytest.fixture(scope="module")
def cold_and_warm(tmp_path_factory):
    """The calls in a fresh process on an empty cache, then in another on the cache it left."""
    cache = tmp_path_factory.mktemp("convimpact-cache")
    before = _package_cache_files()
    cold = _run(CALLS, _env(**{compiled.ENV: str(cache)}))
    after = _package_cache_files()
    warm = _run(CALLS, _env(**{compiled.ENV: str(cache)}))
    return {"cache": cache, "before": before, "after": after, "cold": cold, "warm": warm}


def test_cache_files_go_to_the_cache_folder_not_the_package(cold_and_warm):
    cache = cold_and_warm["cache"]
    out = json.loads(cold_and_warm["cold"].stdout.strip().splitlines()[-1])
    assert out["dir"] and Path(out["dir"]).parent == cache
    written = list(cache.rglob("*.nbi")) + list(cache.rglob("*.nbc"))
    assert len(written) > 10
    assert out["used"]
    for path, base in out["used"]:
        assert Path(path).is_relative_to(cache), (path, base)
        assert (Path(path) / f"{base}.nbi").exists()
    # nothing the calls compiled was written (or rewritten) under the package folder
    before, after = cold_and_warm["before"], cold_and_warm["after"]
    changed = {p for p, t in after.items() if before.get(p) != t}
    bases = {base for _, base in out["used"]}
    ours = {p for p in changed if any(Path(p).name.startswith(b + ".") for b in bases)}
    assert not ours, sorted(ours)[:5]


def test_cold_message_once_per_group_and_none_when_warm(cold_and_warm):
    cold = [ln for ln in cold_and_warm["cold"].stderr.splitlines() if ln.startswith(MESSAGE)]
    assert len(cold) == 2, cold_and_warm["cold"].stderr[-2000:]
    assert sum("single-contact lane" in ln for ln in cold) == 1
    assert sum("batch kernels" in ln for ln in cold) == 1
    for ln in cold:
        assert "first use on this machine, about" in ln
        assert str(cold_and_warm["cache"]) in ln
    warm = cold_and_warm["warm"].stderr
    assert MESSAGE not in warm, warm[-2000:]
    a = json.loads(cold_and_warm["cold"].stdout.strip().splitlines()[-1])
    b = json.loads(cold_and_warm["warm"].stdout.strip().splitlines()[-1])
    assert a["impulse"] == b["impulse"]


def test_unwritable_cache_folder_falls_back_with_a_warning(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    numba_dir = tmp_path / "numba-cache"  # numba's own fallback, out of the package folder
    code = textwrap.dedent("""
        import numpy as np
        import convimpact as ci
        from convimpact import compiled
        r = ci.resolve_impact(np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]]),
                              np.array([0.5, -1.0]), e=0.5, mu=0.0)
        assert compiled._DIR is False
        print(r.impulse.tolist())
    """)
    res = _run(code, _env(**{compiled.ENV: str(blocker / "cache"),
                             "NUMBA_CACHE_DIR": str(numba_dir)}))
    assert json.loads(res.stdout.strip().splitlines()[-1]) == [1.5, 0.0]
    warnings = [ln for ln in res.stderr.splitlines() if "cannot use the compiled-code cache" in ln]
    assert len(warnings) == 1, res.stderr[-2000:]
    assert compiled.ENV in warnings[0]
    assert list(numba_dir.rglob("*.nbi"))  # numba's default locators took over


def _copy_sources(dst: Path) -> Path:
    root = dst / "convimpact"
    shutil.copytree(PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return root


def test_source_key_follows_every_compiled_source(tmp_path):
    root = _copy_sources(tmp_path / "a")
    files = {Path(p).relative_to(root).as_posix(): Path(p).read_bytes()
             for p in compiled.compiled_sources(str(root))}
    kernels = sorted(n for n, text in files.items() if n != "compiled.py"
                     and compiled._DECORATOR.search(text))
    # modules without compiled code that kernels import (constants frozen into machine code)
    imported = sorted(n for n, text in files.items() if not compiled._DECORATOR.search(text)
                      and b"njit(" not in text)
    others = sorted(p.relative_to(root).as_posix() for p in root.rglob("*.py")
                    if p.relative_to(root).as_posix() not in files)
    assert "compiled.py" in files and len(kernels) >= 5 and imported and others
    assert "cli.py" in others
    key = compiled.source_key(str(root))
    assert len(key) == 12 and key == compiled.source_key(str(root))
    other = tmp_path / "b" / "convimpact"  # the key does not depend on where the sources are
    shutil.copytree(root, other)
    assert compiled.source_key(str(other)) == key

    def edited(rel: str, text: str = "\n# edited\n") -> str:
        path = root / rel
        original = path.read_bytes()
        path.write_bytes(original + text.encode())
        try:
            return compiled.source_key(str(root))
        finally:
            path.write_bytes(original)

    # a kernel edited in one module retires the caches of its callers in other modules
    for name in kernels:
        assert edited(name) != key, name
    assert edited("compiled.py") != key  # the jit options
    assert edited(imported[0]) != key, imported[0]
    # a module without compiled code, not imported by any, leaves the caches alone
    assert edited("cli.py") == key
    assert compiled.source_key(str(root)) == key


def test_cache_root_by_platform():
    assert compiled.cache_root({compiled.ENV: "/x/y"}, "linux") == os.path.abspath("/x/y")
    assert compiled.cache_root({"NUMBA_CACHE_DIR": "/n"}, "linux") == os.path.join(
        os.path.abspath("/n"), "convimpact")
    assert compiled.cache_root({"XDG_CACHE_HOME": "/c"}, "linux") == os.path.join(
        "/c", "convimpact")
    assert compiled.cache_root({}, "darwin").endswith(os.path.join(".cache", "convimpact"))
    assert compiled.cache_root({"LOCALAPPDATA": "C:\\L"}, "win32") == os.path.join(
        "C:\\L", "convimpact", "cache")


def test_import_convimpact_does_not_import_numba():
    res = _run("import sys, convimpact, convimpact.compiled; "
               "print('numba' in sys.modules)", _env())
    assert res.stdout.strip() == "False"


# a particle of mass m striking a floor (planar: q = (x, y); spatial: (x, y, z)), every law
DISABLED_JIT = textwrap.dedent("""
    import json
    import numpy as np
    import convimpact as ci
    m, e = 2.0, 0.5
    out = []
    for d in (2, 3):
        M = m * np.eye(d)
        Jc = np.zeros((d, d))
        Jc[0, d - 1] = 1.0  # normal: the vertical coordinate
        for i in range(1, d):
            Jc[i, i - 1] = 1.0  # tangents: the horizontal ones
        dq = np.array([0.3, -0.4][:d - 1] + [-1.0])
        for law in ci.LAWS:
            for mu in (0.0, 0.8):
                r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, law=law)
                out.append([d, law, mu, r.impulse.tolist(), r.dq_plus.tolist(),
                            str(r.regime)])
    print(json.dumps(out))
""")


def test_plain_python_with_numba_disabled():
    res = _run(DISABLED_JIT, _env(NUMBA_DISABLE_JIT="1"))
    assert MESSAGE not in res.stderr
    rows = json.loads(res.stdout.strip().splitlines()[-1])
    assert len(rows) == 2 * len(convimpact.LAWS) * 2
    m, e, vn = 2.0, 0.5, -1.0
    for d, law, mu, impulse, dq_plus, regime in rows:
        vt = [0.3, -0.4][:d - 1]
        pn = -(1.0 + e) * vn * m  # every law: the normal impulse of a particle on a floor
        if mu == 0.0:
            expected = [pn] + [0.0] * (d - 1)
            assert "frictionless" in regime, (d, law, regime)
        else:
            # sticking (mu pn = 2.4 exceeds every tangential impulse below): the tangential
            # velocity stops, or, dissipative (Poisson on the plastic impulse), reverses by e
            k = (1.0 + e) if law == "dissipative" else 1.0
            expected = [pn] + [-k * m * v for v in vt]
            assert "stick" in regime, (d, law, regime)
        assert impulse == pytest.approx(expected, rel=1e-12, abs=1e-12), (d, law, mu)
        v = vt + [vn]
        # dq+ = dq + M^-1 Jc^T pi: the normal row is the last coordinate
        want = [v[i] + expected[i + 1] / m for i in range(d - 1)] + [vn + expected[0] / m]
        assert dq_plus == pytest.approx(want, rel=1e-12, abs=1e-12), (d, law, mu)


def test_prune_keeps_the_recent_and_the_last_used(tmp_path):
    now = time.time()
    ages = {"0.1.0-aaaaaaaaaaaa-numba0.68.1": 30, "0.1.0-bbbbbbbbbbbb-numba0.68.1": 20,
            "0.1.0-cccccccccccc-numba0.68.1": 10, "0.1.0-dddddddddddd-numba0.68.1": 9,
            "0.1.0-eeeeeeeeeeee-numba0.68.1": 1, "not-a-key-folder": 40}
    for name, days in ages.items():
        (tmp_path / name).mkdir()
        os.utime(tmp_path / name, (now - days * 86400.0,) * 2)
    current = tmp_path / "0.1.0-ffffffffffff-numba0.68.1"
    current.mkdir()
    compiled._prune(str(current))
    left = sorted(p.name for p in tmp_path.iterdir())
    # the KEEP last used stay whatever their age; older ones unused for PRUNE_DAYS go
    assert compiled.KEEP == 3 and compiled.PRUNE_DAYS == 7
    assert left == ["0.1.0-cccccccccccc-numba0.68.1", "0.1.0-dddddddddddd-numba0.68.1",
                    "0.1.0-eeeeeeeeeeee-numba0.68.1", current.name, "not-a-key-folder"]


DISABLED_JIT_SIMULATION = textwrap.dedent("""
    import json
    import convimpact as ci
    from convimpact.scenes import load_scene
    from convimpact.simulation.moreau import simulate_moreau
    from convimpact.bench.moreau_scenes import box_row
    table = load_scene("table", legs=4, v0=0.6)
    res = ci.simulate(table)
    stops = [iv.t_start for iv in res.modes_of("leg0") if iv.mode == "stick"]
    mech, q, v = box_row(1, True)
    mj = simulate_moreau(mech, (0.0, 0.1), (q, v), h=0.002, law="coulomb")
    print(json.dumps({"status": res.status, "stop": stops[0] if stops else None,
                      "p": dict(table.parameters), "moreau_speed": float(mj.dtheta[-1][0])}))
""")


def test_simulation_runs_as_plain_python_with_numba_disabled():
    """The simulators' compiled paths (model evaluation, right-hand side, Moreau-Jean steps)
    run as plain Python under NUMBA_DISABLE_JIT=1, with the closed forms: a sliding table
    stops at v0 / (mu g), a box sliding on four corners slows at mu g per second."""
    res = _run(DISABLED_JIT_SIMULATION, _env(NUMBA_DISABLE_JIT="1"))
    out = json.loads(res.stdout.strip().splitlines()[-1])
    p = out["p"]
    assert out["status"] == 0
    assert out["stop"] == pytest.approx(p["v0"] / (p["mu"] * p["gravity"]), rel=1e-8)
    from convimpact.bench.moreau_scenes import GRAVITY, MU, SLIDE_SPEED
    assert out["moreau_speed"] == pytest.approx(SLIDE_SPEED - MU * GRAVITY * 0.1, rel=1e-9)
