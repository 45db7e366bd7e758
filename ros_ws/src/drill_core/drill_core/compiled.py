"""CasADi functions compiled to C and cached on disk: the project's one compile path.

``compiled(functions)`` generates C for the functions (one library; a function ``f``
given together with a function named ``jac_f`` of CasADi's Jacobian signature gets that
Jacobian as its derivative), compiles it with the system C compiler and loads each
function back as an external. The library is cached under a hash of the generated
source, the flags and the CasADi version, so a configuration pays its compilation once
per machine; concurrent builders write to private temporary names and rename atomically.

Compiled and virtual-machine evaluation run the same operations in the same order (no
fast-math, no FMA contraction at the default target), so they agree bit for bit.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path

import casadi as ca

COMPILER_FLAGS = ("-O1", "-fPIC", "-shared")


class CompileError(RuntimeError):
    """The C compiler is missing or rejected the generated source."""


def default_cache_dir() -> Path:
    """Where compiled libraries are kept ($DRILL_COMPILE_CACHE or ~/.cache/drill_rig)."""
    env = os.environ.get("DRILL_COMPILE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "drill_rig"


def compile_library(functions: Sequence[ca.Function], name: str,
                    cache_dir: str | os.PathLike | None = None) -> Path:
    """The cached shared library holding ``functions`` (compiled on first use)."""
    directory = Path(cache_dir) if cache_dir else default_cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    for fn in functions:
        gen.add(fn)
    source = gen.dump()
    key = hashlib.sha256("\n".join([source, " ".join(COMPILER_FLAGS), ca.__version__]).encode())
    library = directory / f"{name}_{key.hexdigest()[:20]}.so"
    if library.exists():
        return library
    compiler = os.environ.get("CC", "gcc")
    with tempfile.TemporaryDirectory(dir=directory) as tmp:
        src = Path(tmp) / f"{name}.c"
        src.write_text(source)
        out = Path(tmp) / "lib.so"
        try:
            subprocess.run([compiler, *COMPILER_FLAGS, "-o", str(out), str(src), "-lm"],
                           check=True, capture_output=True, text=True)
        except FileNotFoundError as exc:
            raise CompileError(f"C compiler {compiler!r} not found (set CC, or turn "
                               f"compilation off in the config)") from exc
        except subprocess.CalledProcessError as exc:
            raise CompileError(f"{compiler} failed on {name}: {exc.stderr.strip()[:2000]}") from exc
        os.replace(out, library)
    return library


def compiled(functions: Sequence[ca.Function], name: str,
             cache_dir: str | os.PathLike | None = None) -> dict[str, ca.Function]:
    """``functions`` compiled into one cached library, loaded back by name."""
    library = compile_library(functions, name, cache_dir)
    return {fn.name(): ca.external(fn.name(), str(library)) for fn in functions}
