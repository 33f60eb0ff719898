# cython: language_level=3
"""The few SQLite C functions the bag loader reads rows with, found at run time in the library Python's own
sqlite3 module uses (no SQLite headers or link at build time)."""
from libc.stdint cimport int64_t

ctypedef int (*open_v2_t)(const char* name, void** db, int flags, const char* vfs) noexcept nogil
ctypedef int (*close_t)(void* db) noexcept nogil
ctypedef int (*busy_timeout_t)(void* db, int ms) noexcept nogil
ctypedef int (*prepare_v2_t)(void* db, const char* sql, int n, void** stmt, const char** tail) noexcept nogil
ctypedef int (*step_t)(void* stmt) noexcept nogil
ctypedef int (*finalize_t)(void* stmt) noexcept nogil
ctypedef int64_t (*column_int64_t)(void* stmt, int col) noexcept nogil
ctypedef const void* (*column_blob_t)(void* stmt, int col) noexcept nogil
ctypedef int (*column_int_t)(void* stmt, int col) noexcept nogil
ctypedef const char* (*errmsg_t)(void* db) noexcept nogil
ctypedef int (*errcode_t)(void* db) noexcept nogil

cdef enum:
    SQLITE_OK = 0
    SQLITE_ROW = 100
    SQLITE_DONE = 101
    SQLITE_BLOB = 4
    SQLITE_OPEN_READONLY = 0x01
    SQLITE_OPEN_URI = 0x40

cdef struct SqliteApi:
    open_v2_t open_v2
    close_t close
    busy_timeout_t busy_timeout
    prepare_v2_t prepare_v2
    step_t step
    finalize_t finalize
    column_int64_t column_int64
    column_blob_t column_blob
    column_int_t column_bytes
    column_int_t column_type
    errmsg_t errmsg
    errcode_t errcode

cdef const SqliteApi* sqlite_api() noexcept
