/* JSON writer (see json.h). */
#include "json.h"

#include <math.h>

static void member(json_writer *j, const char *key)
{
    if (j->count[j->depth]++)
        fputc(',', j->f);
    fputc('\n', j->f);
    for (int i = 0; i < j->depth; i++)
        fputs("  ", j->f);
    if (key) {
        json_write_escaped(j->f, key);
        fputs(": ", j->f);
    }
}

static void open_(json_writer *j, const char *key, char c)
{
    member(j, key);
    fputc(c, j->f);
    if (j->depth < 63)
        j->depth++;
    j->count[j->depth] = 0;
}

static void close_(json_writer *j, char c)
{
    int had = j->count[j->depth];
    j->depth--;
    if (had) {
        fputc('\n', j->f);
        for (int i = 0; i < j->depth; i++)
            fputs("  ", j->f);
    }
    fputc(c, j->f);
}

void json_begin(json_writer *j, FILE *f)
{
    j->f = f;
    j->depth = 0;
    j->count[0] = 0;
    fputc('{', f);
    j->depth = 1;
    j->count[1] = 0;
}

void json_end(json_writer *j)
{
    close_(j, '}');
    fputc('\n', j->f);
}

void json_object(json_writer *j, const char *key) { open_(j, key, '{'); }
void json_object_end(json_writer *j) { close_(j, '}'); }
void json_array(json_writer *j, const char *key) { open_(j, key, '['); }
void json_array_end(json_writer *j) { close_(j, ']'); }

void json_string(json_writer *j, const char *key, const char *value)
{
    member(j, key);
    json_write_escaped(j->f, value ? value : "");
}

static void number_text(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.9g", v);
    else
        fputs("null", f);
}

void json_number(json_writer *j, const char *key, double value)
{
    member(j, key);
    number_text(j->f, value);
}

void json_int(json_writer *j, const char *key, int64_t value)
{
    member(j, key);
    fprintf(j->f, "%lld", (long long)value);
}

void json_bool(json_writer *j, const char *key, int value)
{
    member(j, key);
    fputs(value ? "true" : "false", j->f);
}

/* Short arrays of numbers on one line: [r, g, b]. */
void json_numbers(json_writer *j, const char *key, const double *values, int n)
{
    member(j, key);
    fputc('[', j->f);
    for (int i = 0; i < n; i++) {
        if (i)
            fputs(", ", j->f);
        number_text(j->f, values[i]);
    }
    fputc(']', j->f);
}
