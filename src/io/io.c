/* Files: whole-file reads with a size limit, atomic replacement of outputs. */
#include "internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <time.h>
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
    envl_infile f;
    envl_result rc = envl__infile_open(path, max_bytes, &f);
    if (rc)
        return rc;
    size_t n = (size_t)f.size;
    uint8_t *buf = malloc(n);
    rc = buf ? envl__infile_read(&f, 0, buf, n)
             : envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate %zu bytes", path, n);
    envl__infile_close(&f);
    if (rc) {
        free(buf);
        return rc;
    }
    *data = buf;
    *size = n;
    return ENVL_OK;
}

/* ---- temporaries: DIR/.envl-PID-REST, PID the writing process ---- */

/* A temporary is stale when its process is gone: this host has no such PID, or (the PID
 * reused since, or a process of another host sharing the folder) it has not changed for a day.
 * Only this user's regular files are touched, never this process's own. */
#define STALE_SECONDS (24 * 3600.0)

static int stale_temporary(int dirfd, const char *name, time_t now)
{
    if (strncmp(name, ENVL__TEMP_PREFIX, strlen(ENVL__TEMP_PREFIX)))
        return 0;
    const char *digits = name + strlen(ENVL__TEMP_PREFIX);
    char *end;
    errno = 0;
    long long pid = strtoll(digits, &end, 10);
    if (end == digits || *end != '-' || errno || pid <= 0 || pid > INT32_MAX ||
        pid == (long long)getpid())
        return 0;
    struct stat st;
    if (fstatat(dirfd, name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode) ||
        st.st_uid != geteuid())
        return 0;
    if (kill((pid_t)pid, 0) != 0 && errno == ESRCH)
        return 1;
    return difftime(now, st.st_mtime) > STALE_SECONDS;
}

void envl__remove_stale_temporaries(const char *dir)
{
    DIR *d = opendir(dir && *dir ? dir : ".");
    if (!d)
        return;
    time_t now = time(NULL);
    struct dirent *e;
    while ((e = readdir(d)))
        if (stale_temporary(dirfd(d), e->d_name, now))
            unlinkat(dirfd(d), e->d_name, 0);
    closedir(d);
}

envl_result envl__atomic_begin(const char *path, char **tmp_path)
{
    *tmp_path = NULL;
    /* Same directory as the target, so rename() is atomic: DIR/.envl-PID-NAME.tmp-XXXXXX, the
     * name cut to 100 bytes (a long target name stays within NAME_MAX) */
    const char *slash = strrchr(path, '/');
    int dir_len = slash ? (int)(slash - path + 1) : 0;
    size_t n = strlen(path) + 64;
    char *tmp = malloc(n);
    if (!tmp)
        return envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", path);
    snprintf(tmp, n, "%.*s", dir_len > 1 ? dir_len - 1 : dir_len, path);
    envl__remove_stale_temporaries(dir_len ? tmp : ".");
    snprintf(tmp, n, "%.*s%s%ld-%.100s.tmp-XXXXXX", dir_len, path, ENVL__TEMP_PREFIX,
             (long)getpid(), path + dir_len);
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
