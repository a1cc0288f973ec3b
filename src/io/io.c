/* Files: whole-file reads with a size limit, atomic replacement of outputs. */
#include "internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Fault injection (internal.h): one thread-local increment and compare per write step. */
_Thread_local int64_t envl__io_fail_at, envl__io_calls;

bool envl__io_fault(void)
{
    if (++envl__io_calls != envl__io_fail_at)
        return false;
    errno = ENOSPC;
    return true;
}

envl_result envl__read_file(const char *path, size_t max_bytes, uint8_t **data, size_t *size)
{
    *data = NULL;
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return envl__fail(ENVL_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(f);
        return envl__fail(ENVL_ERR_IO, "%s: not a regular file", path);
    }
    if (st.st_size == 0) {
        fclose(f);
        return envl__fail(ENVL_ERR_FORMAT, "%s: file is empty", path);
    }
    if ((uint64_t)st.st_size > max_bytes) {
        fclose(f);
        return envl__fail(ENVL_ERR_LIMIT, "%s: file of %lld bytes exceeds the limit of %zu bytes",
                          path, (long long)st.st_size, max_bytes);
    }
    size_t n = (size_t)st.st_size;
    uint8_t *buf = malloc(n);
    if (!buf) {
        fclose(f);
        return envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %zu bytes", path, n);
    }
    size_t got = fread(buf, 1, n, f);
    int err = ferror(f);
    fclose(f);
    if (got != n || err) {
        free(buf);
        return envl__fail(ENVL_ERR_IO, "%s: read %zu of %zu bytes", path, got, n);
    }
    *data = buf;
    *size = n;
    return ENVL_OK;
}

envl_result envl__atomic_begin(const char *path, char **tmp_path)
{
    *tmp_path = NULL;
    size_t n = strlen(path);
    char *tmp = malloc(n + 16);
    if (!tmp)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    /* Same directory as the target, so rename() is atomic. Hidden-ish suffix. */
    snprintf(tmp, n + 16, "%s.tmp-XXXXXX", path);
    int fd = envl__io_fault() ? -1 : mkstemp(tmp);
    if (fd < 0) {
        envl_result rc = envl__fail(ENVL_ERR_IO, "%s: cannot create a file there: %s", path,
                                    strerror(errno));
        free(tmp);
        return rc;
    }
    fchmod(fd, 0644);
    close(fd);
    *tmp_path = tmp;
    return ENVL_OK;
}

envl_result envl__atomic_end(const char *path, char *tmp_path, bool ok)
{
    envl_result rc = ENVL_OK;
    if (ok && (envl__io_fault() || rename(tmp_path, path) != 0)) {
        rc = envl__fail(ENVL_ERR_IO, "%s: cannot replace: %s", path, strerror(errno));
        ok = false;
    }
    if (!ok)
        remove(tmp_path);
    free(tmp_path);
    return rc;
}

envl_result envl_file_write_atomic(const char *path, const void *data, size_t size)
{
    if (!path || (!data && size))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_file_write_atomic: NULL argument");
    char *tmp;
    envl_result rc = envl__atomic_begin(path, &tmp);
    if (rc)
        return rc;
    FILE *f = envl__io_fault() ? NULL : fopen(tmp, "wb");
    bool ok = f && !envl__io_fault() && fwrite(data, 1, size, f) == size;
    int err = errno;
    if (f && (fclose(f) != 0 || envl__io_fault())) {
        ok = false;
        err = errno;
    }
    if (!ok) {
        envl__atomic_end(path, tmp, false);
        return envl__fail(ENVL_ERR_IO, "%s: write failed: %s", path, strerror(err));
    }
    return envl__atomic_end(path, tmp, true);
}

envl_result envl__close_written(FILE *f, const char *path, int err)
{
    errno = 0;
    if ((fclose(f) != 0 || envl__io_fault()) && !err)
        err = errno ? errno : EIO;
    if (err)
        return envl__fail(ENVL_ERR_IO, "%s: write failed: %s", path, strerror(err));
    return ENVL_OK;
}
