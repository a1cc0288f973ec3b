/* File names: normalised and relative paths, and no output replacing an input or another output
 * of the same run (envl_outputs_check). Two names are the same file when both exist with the
 * same device and inode (hard links, symbolic links), else when their normalised paths are
 * equal: absolute, the symbolic links of the part that exists resolved (realpath), then ".",
 * ".." and repeated slashes of the rest taken out by name. */
#include "internal.h"

#include <errno.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct file_id {
    const char *name;   /* as given, for the message */
    int exists;
    dev_t dev;
    ino_t ino;
    char *path;         /* normalised; NULL when out of memory */
} file_id;

/* `dir` + "/" + `base` with "." and ".." taken out by name (dir is normalised). */
static char *join(char *dir, const char *base, size_t base_len)
{
    if (!dir)
        return NULL;
    if (base_len == 0 || (base_len == 1 && base[0] == '.'))
        return dir;
    if (base_len == 2 && base[0] == '.' && base[1] == '.') {
        char *slash = strrchr(dir, '/');
        if (slash)
            slash[slash == dir ? 1 : 0] = '\0'; /* "/a" -> "/", "/a/b" -> "/a" */
        return dir;
    }
    size_t n = strlen(dir);
    char *out = realloc(dir, n + base_len + 2);
    if (!out) {
        free(dir);
        return NULL;
    }
    size_t at = n && out[n - 1] == '/' ? n : (out[n] = '/', n + 1);
    memcpy(out + at, base, base_len);
    out[at + base_len] = '\0';
    return out;
}

/* The normalised form of an absolute `path`: realpath when it exists, else that of its folder
 * (recursively) joined with its last part. */
static char *normalised(const char *path)
{
    char *real = realpath(path, NULL);
    if (real)
        return real;
    const char *slash = strrchr(path, '/');
    if (!slash) /* not absolute: cannot happen (absolute() below) */
        return strdup(path);
    if (slash == path)
        return join(strdup("/"), slash + 1, strlen(slash + 1));
    char *dir = strndup(path, (size_t)(slash - path));
    if (!dir)
        return NULL;
    char *ndir = normalised(dir);
    free(dir);
    return join(ndir, slash + 1, strlen(slash + 1));
}

/* `name` made absolute against the working folder. */
static char *absolute(const char *name)
{
    if (name[0] == '/')
        return strdup(name);
    char cwd[PATH_MAX];
    if (!getcwd(cwd, sizeof cwd))
        return strdup(name); /* compared as given */
    size_t n = strlen(cwd) + strlen(name) + 2;
    char *out = malloc(n);
    if (out)
        snprintf(out, n, "%s/%s", cwd, name);
    return out;
}

char *envl__normalised_path(const char *name)
{
    char *abs = absolute(name);
    char *path = abs ? normalised(abs) : NULL;
    free(abs);
    return path;
}

char *envl__relative_path(const char *from, const char *to)
{
    /* the longest common prefix that ends at a component boundary of both */
    size_t common = 0;
    for (size_t k = 0;; k++) {
        int from_end = from[k] == '\0' || from[k] == '/', to_end = to[k] == '\0' || to[k] == '/';
        if (from_end && to_end)
            common = k;
        if (!from[k] || from[k] != to[k])
            break;
    }
    size_t ups = 0; /* from's components after it */
    for (const char *s = from + common; *s; s++)
        ups += s[0] == '/' && s[1] && s[1] != '/';
    const char *rest = to + common;
    while (*rest == '/')
        rest++;
    char *out = malloc(3 * ups + strlen(rest) + 2);
    if (!out)
        return NULL;
    char *q = out;
    for (size_t k = 0; k < ups; k++)
        q += sprintf(q, "../");
    sprintf(q, "%s", *rest || ups ? rest : ".");
    if (ups && !*rest)
        q[-1] = '\0'; /* "../.." rather than "../../" */
    return out;
}

static envl_result identify(const char *name, file_id *id)
{
    id->name = name;
    struct stat st;
    id->exists = stat(name, &st) == 0;
    id->dev = id->exists ? st.st_dev : 0;
    id->ino = id->exists ? st.st_ino : 0;
    id->path = envl__normalised_path(name);
    return id->path ? ENVL_OK : envl__fail(ENVL_ERR_MEMORY, "%s: out of memory", name);
}

static int same_file(const file_id *a, const file_id *b)
{
    if (a->exists && b->exists)
        return a->dev == b->dev && a->ino == b->ino;
    return strcmp(a->path, b->path) == 0;
}

envl_result envl_outputs_check(const char *const *inputs, int32_t n_inputs,
                               const char *const *outputs, int32_t n_outputs)
{
    if (n_inputs < 0 || n_outputs < 0 || (n_inputs && !inputs) || (n_outputs && !outputs))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_outputs_check: bad arguments");
    int32_t n = n_inputs + n_outputs;
    file_id *ids = calloc(n ? (size_t)n : 1, sizeof *ids);
    if (!ids)
        return envl__fail(ENVL_ERR_MEMORY, "envl_outputs_check: out of memory");
    envl_result rc = ENVL_OK;
    for (int32_t i = 0; i < n && !rc; i++) {
        const char *name = i < n_inputs ? inputs[i] : outputs[i - n_inputs];
        if (name && *name)
            rc = identify(name, ids + i);
    }
    /* each output against every input and every output before it */
    for (int32_t o = n_inputs; o < n && !rc; o++) {
        for (int32_t k = 0; k < o && !rc; k++) {
            if (!ids[o].name || !ids[k].name || !same_file(ids + o, ids + k))
                continue;
            if (k < n_inputs)
                rc = envl__fail(ENVL_ERR_ARGUMENT, "%s: the same file as the input %s: an "
                                "output may not replace an input (choose another name)",
                                ids[o].name, ids[k].name);
            else
                rc = envl__fail(ENVL_ERR_ARGUMENT, "%s: the same file as the output %s: two "
                                "outputs of one run may not share a file (choose another "
                                "name)", ids[o].name, ids[k].name);
        }
    }
    for (int32_t i = 0; i < n; i++)
        free(ids[i].path);
    free(ids);
    return rc;
}
