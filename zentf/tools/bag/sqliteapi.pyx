# cython: language_level=3
"""The SQLite C API of the library Python's ``_sqlite3`` module is linked to, resolved with dlopen/dlsym.

Why: reading a rosbag2 .db3 through Python's sqlite3 builds a tuple and a bytes object per message; the bag
loader steps the same query in C instead and hands each row's blob to the compiled decoder in place. The
library is the one Python already loaded (``dlopen`` of ``_sqlite3``'s file with RTLD_NOLOAD, whose
dependencies ``dlsym`` searches), so no SQLite headers or build-time link are needed; if it cannot be found
(a Python built without it, a statically linked one that hides its symbols) ``unavailable()`` says why and
the loader reads rows through Python's sqlite3 as before.
"""
from libc.string cimport memset

__all__ = ["unavailable"]

cdef extern from *:
    """
    /* POSIX dlopen/dlsym; elsewhere (Windows) no library is found and rows go through Python's sqlite3 */
    #if defined(_WIN32)
    static void* zentf_dlopen_loaded(const char* f) { (void)f; return NULL; }
    static void* zentf_dlsym(void* h, const char* s) { (void)h; (void)s; return NULL; }
    #else
    #include <dlfcn.h>
    static void* zentf_dlopen_loaded(const char* f) { return dlopen(f, RTLD_LAZY | RTLD_NOLOAD); }
    static void* zentf_dlsym(void* h, const char* s) { return dlsym(h, s); }
    #endif
    """
    void* dlopen_loaded "zentf_dlopen_loaded"(const char* filename) nogil
    void* dlsym "zentf_dlsym"(void* handle, const char* symbol) nogil

cdef SqliteApi _api
cdef int _state = 0  # 0 not tried, 1 found, -1 not found
cdef str _why = None

_NAMES = (b"sqlite3_open_v2", b"sqlite3_close", b"sqlite3_busy_timeout", b"sqlite3_prepare_v2", b"sqlite3_step",
          b"sqlite3_finalize", b"sqlite3_column_int64", b"sqlite3_column_blob", b"sqlite3_column_bytes",
          b"sqlite3_column_type", b"sqlite3_errmsg", b"sqlite3_errcode")


cdef int _load() noexcept:
    global _state, _why
    cdef void* h
    cdef void* f
    cdef void** slots = <void**>&_api  # a struct of pointers only, in _NAMES' order
    memset(&_api, 0, sizeof(_api))
    try:
        import _sqlite3
        path = _sqlite3.__file__.encode()
    except Exception as e:  # noqa: BLE001 - no sqlite3 module: the Python path says so itself
        _why = f"Python's sqlite3 module is missing ({type(e).__name__})"
        return -1
    h = dlopen_loaded(path)  # the module's own handle, only if it is already loaded
    if h == NULL:
        _why = f"{_sqlite3.__file__} is not loaded"
        return -1
    for i, name in enumerate(_NAMES):
        f = dlsym(h, name)
        if f == NULL:
            _why = f"{name.decode()} not found beside {_sqlite3.__file__}"
            return -1
        slots[i] = f
    return 1


cdef const SqliteApi* sqlite_api() noexcept:
    """The API, or NULL if the library could not be found (``unavailable()`` says why)."""
    global _state
    if _state == 0:
        _state = _load()
    return &_api if _state == 1 else NULL


def unavailable():
    """Why the compiled SQLite path cannot be used (None: it can)."""
    sqlite_api()
    return _why
