/* Input files read by offset (pread): the readers that stream a file (hdr.c, exr.c) hold a few
 * windows of it, never the whole file, and read the bytes they need from any thread. No mmap:
 * a file truncated by another program while it is read would kill the process with SIGBUS
 * instead of giving an error. */
#include "internal.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

envl_result envl__infile_open(const char *path, uint64_t max_bytes, envl_infile *f)
{
    memset(f, 0, sizeof *f);
    f->fd = -1;
    f->path = path;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return envl__fail(ENVL_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return envl__fail(ENVL_ERR_IO, "%s: not a regular file", path);
    }
    if (st.st_size == 0) {
        close(fd);
        return envl__fail(ENVL_ERR_FORMAT, "%s: file is empty", path);
    }
    if ((uint64_t)st.st_size > max_bytes) {
        close(fd);
        return envl__fail(ENVL_ERR_LIMIT, "%s: file of %lld bytes exceeds the limit of %llu bytes",
                          path, (long long)st.st_size, (unsigned long long)max_bytes);
    }
    f->fd = fd;
    f->size = (uint64_t)st.st_size;
    f->mtime_ns = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
    return ENVL_OK;
}

envl_result envl__infile_read(const envl_infile *f, uint64_t offset, void *buf, size_t n)
{
    uint8_t *p = buf;
    size_t done = 0;
    while (done < n) {
        ssize_t got = pread(f->fd, p + done, n - done, (off_t)(offset + done));
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0)
            return envl__fail(ENVL_ERR_IO, "%s: read of %zu bytes at byte %llu failed: %s",
                              f->path, n, (unsigned long long)offset, strerror(errno));
        if (got == 0)
            return envl__fail(ENVL_ERR_IO, "%s: the file shrank while it was read (%zu bytes "
                              "expected at byte %llu, %zu there)", f->path, n,
                              (unsigned long long)offset, done);
        done += (size_t)got;
    }
    return ENVL_OK;
}

envl_result envl__infile_unchanged(const envl_infile *f)
{
    struct stat st;
    if (fstat(f->fd, &st) != 0)
        return envl__fail(ENVL_ERR_IO, "%s: cannot check the file after reading it: %s",
                          f->path, strerror(errno));
    int64_t mtime = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
    if ((uint64_t)st.st_size != f->size || mtime != f->mtime_ns)
        return envl__fail(ENVL_ERR_IO, "%s: the file changed while it was read (another program "
                          "wrote it): read it again", f->path);
    return ENVL_OK;
}

void envl__infile_close(envl_infile *f)
{
    if (f && f->fd >= 0)
        close(f->fd);
    if (f)
        f->fd = -1;
}
