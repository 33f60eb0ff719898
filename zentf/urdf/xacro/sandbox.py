"""The child process that expands a model, confined by the kernel before it reads a byte of it.

Belt and braces under the restricted evaluator: even a flaw in it could not run a command, write a
file, open a socket or read outside the allowed folders, nor spend more than the budget.

- it dies with its parent (``PR_SET_PDEATHSIG``);
- rlimits: ``RLIMIT_CPU`` (the budget's seconds, then SIGXCPU/SIGKILL), ``RLIMIT_AS`` (the budget's
  memory over what the interpreter already uses), ``RLIMIT_FSIZE`` 0 (no file can be written),
  ``RLIMIT_NPROC`` 0 (no process can be started), ``RLIMIT_CORE`` 0;
- Landlock (Linux >= 5.13, when enabled): the process may only read files and list folders under
  the allowed roots; it may not write, create, remove or execute anything anywhere, nor (ABI >= 4)
  bind or connect TCP sockets, nor (ABI >= 6) reach abstract UNIX sockets or signal other processes.
  ``no_new_privs`` is set first, as Landlock requires.

Without Landlock (other kernels, other systems) the rlimits and the evaluator's own rules remain.
The request comes on stdin as JSON, the answer goes to stdout as JSON; the environment is empty.
"""
from __future__ import annotations

import ctypes
import json
import math
import os
import platform
import struct
import sys

__all__ = ["confine", "landlock_abi", "main"]

_SYS_CREATE, _SYS_ADD_RULE, _SYS_RESTRICT = 444, 445, 446  # the same number on every 64-bit Linux arch
_PR_SET_NO_NEW_PRIVS = 38
_PR_SET_PDEATHSIG = 1
_RULE_PATH_BENEATH = 1
_FS_EXECUTE, _FS_WRITE_FILE, _FS_READ_FILE, _FS_READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
_NET_ALL = (1 << 0) | (1 << 1)        # bind and connect TCP (ABI 4)
_SCOPE_ALL = (1 << 0) | (1 << 1)      # abstract UNIX sockets, signals (ABI 6)


def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux") or platform.machine() not in ("x86_64", "aarch64", "riscv64",
                                                                          "ppc64le", "s390x", "loongarch64"):
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
    except OSError:
        return None
    libc.syscall.restype = ctypes.c_long
    return libc


def landlock_abi() -> int:
    """The kernel's Landlock ABI version, 0 when there is none."""
    libc = _libc()
    if libc is None:
        return 0
    v = libc.syscall(ctypes.c_long(_SYS_CREATE), None, ctypes.c_size_t(0), ctypes.c_uint32(1))
    return int(v) if v > 0 else 0


def _fs_rights(abi: int) -> int:
    bits = 13 + (abi >= 2) + (abi >= 3)  # REFER (2), TRUNCATE (3)
    rights = (1 << bits) - 1
    if abi >= 5:
        rights |= 1 << 15                 # IOCTL_DEV
    return rights


def _landlock(read_roots: list[str]) -> int:
    """Confine this process to reading under ``read_roots``; the ABI used, 0 if Landlock is unavailable."""
    abi = landlock_abi()
    if abi < 1:
        return 0
    libc = _libc()
    assert libc is not None
    fields = [_fs_rights(abi)] + ([_NET_ALL] if abi >= 4 else []) + ([_SCOPE_ALL] if abi >= 6 else [])
    attr = struct.pack(f"={len(fields)}Q", *fields)
    buf = ctypes.create_string_buffer(attr, len(attr))
    fd = libc.syscall(ctypes.c_long(_SYS_CREATE), buf, ctypes.c_size_t(len(attr)), ctypes.c_uint32(0))
    if fd < 0:
        raise OSError(ctypes.get_errno(), "landlock_create_ruleset failed")
    try:
        for root in read_roots:
            if not os.path.isdir(root):
                continue
            pfd = os.open(root, os.O_PATH | os.O_CLOEXEC)
            try:
                rule = struct.pack("=Qi", _FS_READ_FILE | _FS_READ_DIR, pfd)
                rbuf = ctypes.create_string_buffer(rule, len(rule))
                if libc.syscall(ctypes.c_long(_SYS_ADD_RULE), ctypes.c_int(fd), ctypes.c_int(_RULE_PATH_BENEATH),
                                rbuf, ctypes.c_uint32(0)) < 0:
                    raise OSError(ctypes.get_errno(), f"landlock_add_rule failed for {root}")
            finally:
                os.close(pfd)
        if libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_NO_NEW_PRIVS) failed")
        if libc.syscall(ctypes.c_long(_SYS_RESTRICT), ctypes.c_int(fd), ctypes.c_uint32(0)) < 0:
            raise OSError(ctypes.get_errno(), "landlock_restrict_self failed")
    finally:
        os.close(fd)
    return abi


def _vm_bytes() -> int:
    try:
        with open("/proc/self/statm", "rb") as f:
            return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 256 * 1024 * 1024


def confine(read_roots: list[str], cpu_s: float, memory_bytes: int) -> dict:
    """Limit this process (see the module doc); what was applied, for the parent's debug log."""
    applied: dict = {"landlock": 0, "rlimits": False}
    try:
        import resource
    except ImportError:  # pragma: no cover - not a POSIX system
        resource = None  # type: ignore[assignment]
    if resource is not None:
        vm = _vm_bytes()
        cpu = int(math.ceil(cpu_s))
        limits = [(resource.RLIMIT_CPU, cpu + 1, cpu + 2), (resource.RLIMIT_FSIZE, 0, 0),
                  (resource.RLIMIT_CORE, 0, 0), (resource.RLIMIT_AS, vm + memory_bytes, vm + memory_bytes)]
        if hasattr(resource, "RLIMIT_NPROC"):
            limits.append((resource.RLIMIT_NPROC, 0, 0))
        for which, soft, hard in limits:
            try:
                old_soft, old_hard = resource.getrlimit(which)
                if old_hard != resource.RLIM_INFINITY:
                    hard = min(hard, old_hard)
                    soft = min(soft, hard)
                resource.setrlimit(which, (soft, hard))
            except (ValueError, OSError):
                pass
        applied["rlimits"] = True
    libc = _libc()
    if libc is not None:  # the expansion ends with its parent, whatever happens to the parent
        libc.prctl(_PR_SET_PDEATHSIG, 9, 0, 0, 0)
        if os.getppid() == 1:
            os._exit(1)
    applied["landlock"] = _landlock(read_roots)
    return applied


def _reply(obj: dict) -> None:
    data = json.dumps(obj, ensure_ascii=True).encode("ascii")
    os.write(1, len(data).to_bytes(8, "big"))
    view = memoryview(data)
    while view:
        n = os.write(1, view)
        view = view[n:]


def main() -> int:
    """Read the request, confine, expand, answer. Exit status 0 whenever an answer was written."""
    from . import budget as budget_mod, expand as expand_mod, errors  # everything imported before confining
    import yaml  # noqa: F401 - (load_yaml imports it lazily otherwise)
    import glob, fnmatch, keyword, ast, re, string, operator  # noqa: E401,F401

    raw = sys.stdin.buffer.read(4 * 1024 * 1024)
    try:
        req = json.loads(raw)
        budget = budget_mod.Budget(float(req["budget"]["cpu_s"]), int(req["budget"]["memory_mb"]))
        roots = [str(r) for r in req["roots"]]
    except (ValueError, KeyError, TypeError) as e:
        _reply({"ok": False, "error": f"bad request to the xacro process: {e}"})
        return 0
    sys.setrecursionlimit(6000)
    applied = confine(roots, budget.cpu_s, budget.memory_bytes)
    try:
        text, warnings = expand_mod.expand(
            req["path"], roots=roots, search=list(req.get("search", [])), packages=dict(req.get("packages", {})),
            args=dict(req.get("args", {})), env=dict(req.get("env", {})), cwd=str(req.get("cwd", "/")),
            budget=budget)
    except errors.XacroError as e:
        _reply({"ok": False, "error": e.message, "file": e.file, "line": e.line, "confined": applied})
        return 0
    except MemoryError:
        _reply({"ok": False, "budget": "memory", "confined": applied})
        return 0
    except RecursionError:
        _reply({"ok": False, "error": "the model nests macros, properties or expressions too deeply",
                "confined": applied})
        return 0
    _reply({"ok": True, "urdf": text, "warnings": warnings, "confined": applied})
    return 0
