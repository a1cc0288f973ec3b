/* The JSON writer of every JSON envlight writes (the library's prefilter.json and the command
 * line's outputs; json.c is compiled into both): keys in insertion order, numbers with 9
 * significant digits, non-finite numbers as null, strings escaped (valid UTF-8 whatever the
 * bytes of a file name). */
#ifndef ENVL_JSON_H
#define ENVL_JSON_H

#include <stdint.h>
#include <stdio.h>

typedef struct json_writer {
    FILE *f;
    int depth;
    int count[64]; /* members written at each depth */
} json_writer;

void json_begin(json_writer *j, FILE *f);           /* opens the top-level object */
void json_end(json_writer *j);                       /* closes it, newline */
void json_object(json_writer *j, const char *key);   /* key NULL inside arrays */
void json_object_end(json_writer *j);
void json_array(json_writer *j, const char *key);
void json_array_end(json_writer *j);
void json_string(json_writer *j, const char *key, const char *value);
void json_number(json_writer *j, const char *key, double value);
void json_int(json_writer *j, const char *key, int64_t value);
void json_bool(json_writer *j, const char *key, int value);
void json_numbers(json_writer *j, const char *key, const double *values, int n);

#endif
