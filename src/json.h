/* A small JSON writer for the CLI: keys in insertion order, numbers with 9 significant
 * digits, non-finite numbers as null, strings escaped. */
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
/* Writes `s` as a JSON string literal (quotes included). */
void json_write_escaped(FILE *f, const char *s);

#endif
