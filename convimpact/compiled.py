"""How convimpact compiles: the one numba decorator, and where its machine code is kept.

Every compiled function of convimpact is decorated with :data:`jit`
(``numba.njit(cache=True, nogil=True, error_model="numpy")``), imported as
``from convimpact.compiled import jit`` (or relatively). numba is imported only when ``jit`` is
first read -- by a kernel module, itself imported on first use -- so ``import convimpact`` and
``import convimpact.compiled`` stay without numba. :data:`jit_internal` adds
``no_cpython_wrapper`` and ``no_cfunc_wrapper`` for functions called from compiled code only
(they cannot be called from Python, except under ``NUMBA_DISABLE_JIT=1``). :data:`jit_inline`
adds numba's ``inline="always"``: a compiled caller takes the function's body into its own
(numba's IR, before typing), which it then compiles once. It is meant for the drivers between
an entry point and its large kernels: numba compiles every function into its own module, and
each caller's module links, optimizes and emits again everything below it, so a chain of
drivers above the interior point compiled the interior point four times over; inlined, the
entry point links the kernels once. (Small leaf functions stay separate: inlining them made
numba's typing of their caller slower than compiling them apart.) Such a function is still an
ordinary compiled function when called from Python.

A constant argument (``f(x, True)``) in compiled code makes numba compile the callee for that
value (a literal type): a flag passed as ``True`` at one call site and ``False`` at another
compiles the callee twice, and every function below it that receives the flag too. Kernels
pass such flags as run-time booleans (``bool(True)``) unless the specialization is wanted.

numba keeps the machine code of a ``cache=True`` function on disk, by default in
``__pycache__`` beside its source, and checks it against that one source file. Both defaults
fail convimpact: an installed package collects cache files that pip's uninstall does not
remove (the left-over folder then shadows a later editable install), and a kernel edited in
one module leaves stale copies of itself in the machine code of its callers in other modules.
Reading :data:`jit` therefore registers a cache locator, ahead of numba's own, that takes the
functions whose source file lies inside the convimpact package and keeps their cache in

* ``$CONVIMPACT_CACHE_DIR`` when it is set, else
* ``$NUMBA_CACHE_DIR/convimpact`` when numba's caches were moved (a read-only home, a
  throw-away cache for a cold measurement), else
* ``$XDG_CACHE_HOME/convimpact`` or ``~/.cache/convimpact`` (Linux, macOS), or
  ``%LOCALAPPDATA%\\convimpact\\cache`` (Windows),

in a subfolder named by convimpact's version, :func:`source_key` (a short hash of every
source file that holds compiled code and of the package modules they import, so editing any
kernel, or a constant one freezes, retires every cache that may embed it) and numba's
version. A cache folder that cannot be created or written falls back, with one warning, to
numba's own locators (``$NUMBA_CACHE_DIR``, else ``__pycache__``); it never fails a call.
Folders of other keys left by earlier sources are removed once unused for
:data:`PRUNE_DAYS` days (the :data:`KEEP` most recently used are always kept).

:func:`announce` prints one line on stderr before an entry point compiles on a cold cache,
so a first call's wait of several seconds says what it is.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import sys
import tempfile
import time
import types
import warnings

#: the folder of the convimpact package: functions whose source lies in it are cached here
#: (``problems/``, installed as ``convimpact.problems``, holds no compiled code)
PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
#: the environment variable that moves the cache
ENV = "CONVIMPACT_CACHE_DIR"
#: the options of every compiled function
JIT_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}
#: ... and of a function called from compiled code only (:data:`jit_internal`): no CPython or
#: cfunc wrapper to generate (a few per cent of the several-contact lane's cold compile when
#: its internal functions were decorated so, within the noise of a shared machine)
JIT_INTERNAL_OPTIONS = {**JIT_OPTIONS, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
#: ... and of a function whose body compiled callers take into their own (:data:`jit_inline`)
JIT_INLINE_OPTIONS = {**JIT_OPTIONS, "inline": "always"}
#: folders of other source keys unused for this many days are removed ...
PRUNE_DAYS = 7
#: ... except the most recently used few
KEEP = 3

# a numba decorator (bare or dotted), or a call of njit: the file holds compiled code
_DECORATOR = re.compile(
    rb"@(?:\w+\.)?(?:_?jit|jit_internal|njit|_int|intrinsic|overload\w*|register_jitable|"
    rb"vectorize|guvectorize|cfunc|generated_jit)\b")
# relative imports, of a module or of modules of a package (the first line of the names)
_RELATIVE_IMPORT = re.compile(rb"from[ \t]+(\.+)([\w.]*)[ \t]+import[ \t]+\(?([\w \t,]*)")
_KEY_DIR = re.compile(r"^.+-[0-9a-f]{12}-numba.+$")

_DIR = None  # the usable cache folder of this process (str), False: unusable, None: not yet
_JIT = _JIT_INTERNAL = _JIT_INLINE = None
_ANNOUNCED: set[str] = set()
_PLAIN: dict = {}  # py_func -> its plain twin (:func:`plain`)
#: seconds the source key took in this process (hashing at the first kernel import)
KEY_SECONDS: list[float] = []


def cache_root(environ=None, platform: str | None = None) -> str:
    """The folder that holds convimpact's compiled caches (of every source key)."""
    env = os.environ if environ is None else environ
    platform = sys.platform if platform is None else platform
    if env.get(ENV):
        return os.path.abspath(os.path.expanduser(env[ENV]))
    if env.get("NUMBA_CACHE_DIR"):  # numba's caches moved on purpose: convimpact's go along
        return os.path.join(os.path.abspath(os.path.expanduser(env["NUMBA_CACHE_DIR"])),
                            "convimpact")
    if platform.startswith("win"):
        base = env.get("LOCALAPPDATA") or os.path.join(os.path.expanduser("~"), "AppData",
                                                       "Local")
        return os.path.join(base, "convimpact", "cache")
    base = env.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "convimpact")


def _python_sources(root: str) -> dict[str, bytes]:
    out = {}
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(s for s in subfolders if s != "__pycache__"
                               and not s.startswith("."))
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                try:
                    with open(path, "rb") as f:
                        out[path] = f.read()
                except OSError:
                    pass
    return out


def _module_file(sources: dict, base: str, parts: list[str]) -> str | None:
    path = os.path.join(base, *parts)
    for candidate in (path + ".py", os.path.join(path, "__init__.py")):
        if candidate in sources:
            return candidate
    return None


def compiled_sources(root: str = PACKAGE_DIR, sources: dict | None = None) -> list[str]:
    """The .py files under ``root`` that hold compiled code (a numba decorator or ``njit``
    call), with the package modules they import from, transitively (the constants a kernel
    reads are frozen into its machine code, whichever module defines them); sorted."""
    sources = _python_sources(root) if sources is None else sources
    seeds = [p for p, text in sources.items()
             if b"njit(" in text or (b"@" in text and _DECORATOR.search(text) is not None)]
    seen, todo = set(seeds), list(seeds)
    while todo:
        path = todo.pop()
        for dots, module, names in _RELATIVE_IMPORT.findall(sources[path]):
            base = os.path.dirname(path)
            for _ in range(len(dots) - 1):
                base = os.path.dirname(base)
            parts = [p for p in module.decode().split(".") if p]
            found = [_module_file(sources, base, parts)] if parts else []
            for name in names.decode().replace("\t", " ").split(","):
                name = name.strip().split(" ")[0]
                if name:  # the name may be a module of the package
                    found.append(_module_file(sources, base, parts + [name]))
            if not parts and found.count(None) == len(found):
                # names of the package's __init__ itself
                found.append(_module_file(sources, base, []))
            for p in found:
                if p is not None and p not in seen:
                    seen.add(p)
                    todo.append(p)
    return sorted(seen)


def source_key(root: str = PACKAGE_DIR) -> str:
    """A short hash (12 hex digits) of the contents and relative paths of
    :func:`compiled_sources` under ``root``: it changes whenever a compiled function, or
    anything it may embed, is edited."""
    sources = _python_sources(root)
    h = hashlib.sha256()
    for path in compiled_sources(root, sources):
        h.update(os.path.relpath(path, root).replace(os.sep, "/").encode())
        h.update(b"\0")
        h.update(hashlib.sha256(sources[path]).digest())
    return h.hexdigest()[:12]


def _version() -> str:
    v = getattr(sys.modules.get("convimpact"), "__version__", None)
    if v is None:  # convimpact/__init__.py still running
        try:
            from importlib.metadata import version

            v = version("convimpact")
        except Exception:
            v = "0"
    return str(v)


def cache_dir() -> str:
    """This process's cache folder: :func:`cache_root` / ``<version>-<source_key>-numba<v>``
    (the key is hashed once per process; numba is imported)."""
    import numba

    t = time.perf_counter()
    key = source_key()
    KEY_SECONDS.append(time.perf_counter() - t)
    return os.path.join(cache_root(), f"{_version()}-{key}-numba{numba.__version__}")


def _prune(path: str) -> None:
    """Remove sibling folders of other keys unused for PRUNE_DAYS days (not the KEEP most
    recently used); errors are ignored."""
    root = os.path.dirname(path)
    try:
        others = [e for e in os.scandir(root) if e.is_dir(follow_symlinks=False)
                  and _KEY_DIR.match(e.name) and e.path != path]
        others.sort(key=lambda e: e.stat().st_mtime, reverse=True)
        old = time.time() - PRUNE_DAYS * 86400.0
        for e in others[KEEP:]:
            if e.stat().st_mtime < old:
                shutil.rmtree(e.path, ignore_errors=True)
    except OSError:
        pass


def _usable_dir():
    """The cache folder, created and tested writable once per process; False (with one
    warning) when it cannot be."""
    global _DIR
    if _DIR is None:
        path = "?"
        try:
            path = cache_dir()
            new = not os.path.isdir(path)
            os.makedirs(path, exist_ok=True)
            tempfile.TemporaryFile(dir=path).close()
            os.utime(path)  # marks it used (pruning keeps the recently used)
            if new:
                _prune(path)
            _DIR = path
        except OSError as exc:
            _DIR = False
            warnings.warn(
                f"convimpact: cannot use the compiled-code cache {path} ({exc}); numba's "
                f"default cache ($NUMBA_CACHE_DIR, else __pycache__ beside the sources) is used "
                f"instead. Set {ENV} to a writable folder.", RuntimeWarning, stacklevel=2)
    return _DIR


def _inside(path: str, folder: str) -> bool:
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:  # other drive (Windows)
        return False


def _locator_class():
    """numba's cache locator for convimpact's functions (numba imported)."""
    from numba.core import caching

    package = os.path.realpath(PACKAGE_DIR)

    class ConvimpactCacheLocator(caching._CacheLocator):
        """Keeps the cache of a function defined inside the convimpact package in
        :func:`cache_dir` (a subfolder per package folder); declines every other function."""

        def __init__(self, py_func, py_file, path, stamp):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = path
            self._stamp = stamp

        def get_cache_path(self):
            return self._cache_path

        def ensure_cache_path(self):
            # the folder was tested writable once per process (_usable_dir); numba's base
            # class would create a temporary file for every function
            os.makedirs(self._cache_path, exist_ok=True)

        def get_source_stamp(self):
            # the folder's key already covers this file and everything it may embed
            return self._stamp

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            if not py_file or not os.path.isfile(py_file):
                return None
            source = os.path.realpath(py_file)
            if not _inside(source, package):
                return None
            root = _usable_dir()
            if not root:
                return None
            rel = os.path.relpath(os.path.dirname(source), package)
            path = root if rel == os.curdir else os.path.join(root, rel)
            self = cls(py_func, py_file, path, os.path.basename(root))
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    return ConvimpactCacheLocator


def _register() -> None:
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # numba < 0.62: private
    classes = impl._locator_classes
    if not any(c.__name__ == "ConvimpactCacheLocator" for c in classes):
        classes.insert(0, _locator_class())


def cached(dispatcher) -> bool:
    """Whether the disk cache holds machine code of ``dispatcher`` for its current source
    (True when it cannot tell, or when the function is not compiled: NUMBA_DISABLE_JIT)."""
    cache = getattr(dispatcher, "_cache", None)
    if cache is None:
        return True
    try:
        return bool(cache._cache_file._load_index())
    except Exception:
        return True


def announce(what: str, seconds: float, *dispatchers) -> bool:
    """Before the first call of compiled entry points in this process: when none of
    ``dispatchers`` has machine code in the cache (a first use on this machine, or after an
    edit or an upgrade of the sources), print one line on stderr saying that ``what``
    compiles now, about how long it takes (``seconds``, measured on a 2-core machine) and
    where it is cached. Entry points that share most of their callees are named together:
    once one is cached, the others compile in a fraction of the time. Once per ``what`` and
    process; returns whether it printed."""
    if what in _ANNOUNCED:
        return False
    _ANNOUNCED.add(what)
    if not dispatchers or any(cached(d) for d in dispatchers):
        return False
    where = _DIR or getattr(getattr(dispatchers[0], "_cache", None), "cache_path", "?")
    print(f"convimpact: compiling the {what} (first use on this machine, about "
          f"{seconds:.0f} s; cached in {where})", file=sys.stderr, flush=True)
    return True


class LawEntries:
    """Calls of a compiled driver whose leading arguments -- a law's code, and for some drivers
    the contact dimension -- it compiles for as constants (``literally``): each law (and
    dimension) compiles only when first used. numba's dispatcher would type the constants
    again on every call (milliseconds); after the first call with given constants this keeps
    the machine code's entry for them and calls that (a fraction of a microsecond).
    ``literals`` is how many leading arguments are constants (1: the law; 2: law and
    dimension). The other arguments must keep the types of the first call (C-contiguous
    float64 arrays, floats).
    """

    __slots__ = ("dispatcher", "entries", "literals")

    def __init__(self, dispatcher, literals: int = 1):
        self.dispatcher = dispatcher
        self.entries: dict = {}
        self.literals = literals

    def __call__(self, *args):
        key = args[:self.literals]
        entry = self.entries.get(key)
        if entry is not None:
            return entry(*args)
        if key:
            # compile (or load) the constants' specialization directly: called with plain
            # integers, numba would first run its front end on them, meet ``literally`` and
            # start again (a quarter of a second for the batch driver)
            try:
                from numba import typeof, types
                from numba.core.typing.typeof import Purpose

                self.dispatcher.compile(tuple(types.literal(k) for k in key) + tuple(
                    typeof(a, Purpose.argument) for a in args[self.literals:]))
            except Exception:  # noqa: BLE001 - numba's own dispatch below decides
                pass
            entry = self._entry(key)
            if entry is not None:
                return entry(*args)
        result = self.dispatcher(*args)  # compiles, or loads from the cache
        self._entry(key)
        return result

    def _entry(self, key):
        """The machine code's entry of the one specialization for constants ``key`` (kept),
        or None."""
        found = [cres.entry_point for sig, cres in getattr(self.dispatcher, "overloads",
                                                             {}).items()
                 if all(getattr(t, "literal_value", None) == k for t, k in zip(sig, key))]
        if len(found) == 1:  # one specialization for these constants: its entry serves all
            self.entries[key] = found[0]
            return found[0]
        return None


def _plain(fn):
    """The decorator without numba: the function itself, run by Python."""
    return fn


def plain(fn):
    """The compiled function ``fn`` as plain Python: its own source, with every compiled
    function it calls by name replaced by that function's plain version (recursively), as
    ``NUMBA_DISABLE_JIT=1`` would run it, but for this call tree only. For a first call that
    should not wait for a compilation (small problems, before the machine code is cached);
    the answers are the compiled code's to round-off. ``fn`` itself when it is not compiled."""
    py = getattr(fn, "py_func", None)
    if py is None:
        return fn
    done = _PLAIN.get(py)
    if done is not None:
        return done
    scope = dict(py.__globals__)
    twin = types.FunctionType(py.__code__, scope, py.__name__, py.__defaults__, py.__closure__)
    _PLAIN[py] = twin
    for name in py.__code__.co_names:
        if hasattr(scope.get(name), "py_func"):
            scope[name] = plain(scope[name])
    return twin


def __getattr__(name):
    # numba is imported here, on the first read of ``jit``, ``jit_internal`` or ``jit_inline``
    # (by a kernel module)
    global _JIT, _JIT_INTERNAL, _JIT_INLINE
    if name in ("jit", "jit_internal", "jit_inline"):
        if _JIT is None:
            try:
                from numba import njit
            except ImportError as exc:  # the same code, run as plain Python
                warnings.warn(
                    f"numba could not be imported ({exc}): convimpact's kernels run as plain "
                    "Python -- the same code and answers, some 100 times slower; install "
                    "numba (a dependency of convimpact) for compiled speed", RuntimeWarning,
                    stacklevel=2)
                _JIT = _JIT_INTERNAL = _JIT_INLINE = _plain
            else:
                _register()
                _JIT = njit(**JIT_OPTIONS)
                _JIT_INTERNAL = njit(**JIT_INTERNAL_OPTIONS)
                _JIT_INLINE = njit(**JIT_INLINE_OPTIONS)
        return {"jit": _JIT, "jit_internal": _JIT_INTERNAL, "jit_inline": _JIT_INLINE}[name]
    if name == "literally":  # compile for a value as a constant; the value itself in Python
        try:
            from numba import literally
        except ImportError:
            return _plain
        return literally
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    # dir() and tab completion list the decorators read on first use too
    return sorted(set(globals()) | {"jit", "jit_internal", "jit_inline", "literally"})


__all__ = ["jit", "jit_internal", "jit_inline", "literally", "plain", "JIT_OPTIONS",
           "JIT_INTERNAL_OPTIONS", "JIT_INLINE_OPTIONS", "ENV", "cache_root",
           "cache_dir", "compiled_sources", "source_key", "cached", "announce"]
