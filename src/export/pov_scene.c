/* A tolerant token scan of a POV-Ray 3.7 scene: what it places and which effects it uses.
 * One pass over the tokens keeps brace depth, the #if/#while/#macro nesting, the current
 * #declare and the current top-level object; short bounded look-aheads read the values that
 * matter (a finish's amount, a plane's normal and height, a pigment's colour). Nothing
 * recurses, every look-ahead reads a fixed number of tokens, so the scan is linear in the size. */
#include "pov_scene.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---- notes ---- */

static void note(pov_scene *out, const char *fmt, ...)
{
    if (out->note[0])
        return; /* only the first problem */
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out->note, sizeof out->note, fmt, ap);
    va_end(ap);
}

/* ---- lexer ---- */

enum { T_EOF, T_IDENT, T_NUMBER, T_STRING, T_DIRECTIVE, T_PUNCT };

typedef struct token {
    int kind;
    const char *s; /* identifier or directive name (not terminated) */
    size_t n;
    double value;  /* T_NUMBER */
    int c;         /* T_PUNCT: the byte */
    int line;
} token;

typedef struct lexer {
    const char *p, *end;
    int line; /* at most 64 Mi lines: fits an int */
    pov_scene *out;
} lexer;

static int is_ident_start(int c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
static int is_digit(int c) { return c >= '0' && c <= '9'; }
static int is_ident_char(int c) { return is_ident_start(c) || is_digit(c); }

/* A decimal literal `12`, `1.5`, `.5`, `1.`, `2e-3`; its value from at most 18 significant
 * digits (m / 10^k with both exact is correctly rounded; plenty for amounts and colours). */
static double lex_number(lexer *lx)
{
    unsigned long long m = 0;
    int sig = 0, exp10 = 0;
    const char *p = lx->p, *end = lx->end;
    for (; p < end && is_digit((unsigned char)*p); p++) {
        if (sig < 18) {
            m = m * 10 + (unsigned)(*p - '0');
            if (m)
                sig++;
        } else {
            exp10++;
        }
    }
    if (p < end && *p == '.') {
        for (p++; p < end && is_digit((unsigned char)*p); p++) {
            if (sig < 18) {
                m = m * 10 + (unsigned)(*p - '0');
                if (m)
                    sig++;
                exp10--;
            }
        }
    }
    if (p < end && (*p == 'e' || *p == 'E')) {
        const char *q = p + 1;
        int sign = 1;
        if (q < end && (*q == '+' || *q == '-'))
            sign = *q++ == '-' ? -1 : 1;
        if (q < end && is_digit((unsigned char)*q)) {
            int e = 0;
            for (; q < end && is_digit((unsigned char)*q); q++)
                if (e < 100000)
                    e = e * 10 + (*q - '0');
            exp10 += sign * e;
            p = q;
        }
    }
    lx->p = p;
    if (m == 0)
        return 0.0;
    if (exp10 > 400)
        exp10 = 400;
    if (exp10 < -400)
        exp10 = -400;
    return exp10 >= 0 ? (double)m * pow(10.0, exp10) : (double)m / pow(10.0, -exp10);
}

/* Skips whitespace, `//` comments and nested block comments (POV-Ray nests them; `//` inside
 * a block comment means nothing). */
static void lex_skip(lexer *lx)
{
    const char *p = lx->p, *end = lx->end;
    for (;;) {
        while (p < end && (unsigned char)*p <= ' ') {
            if (*p == '\n')
                lx->line++;
            p++;
        }
        if (end - p >= 2 && p[0] == '/' && p[1] == '/') {
            while (p < end && *p != '\n' && *p != '\r')
                p++;
            continue;
        }
        if (end - p >= 2 && p[0] == '/' && p[1] == '*') {
            int opened = lx->line;
            long depth = 1; /* at most one per two bytes of 64 MiB */
            p += 2;
            while (p < end && depth > 0) {
                if (end - p >= 2 && p[0] == '*' && p[1] == '/') {
                    depth--;
                    p += 2;
                } else if (end - p >= 2 && p[0] == '/' && p[1] == '*') {
                    depth++;
                    p += 2;
                } else {
                    if (*p == '\n')
                        lx->line++;
                    p++;
                }
            }
            if (depth > 0)
                note(lx->out, "line %d: unterminated /* comment", opened);
            continue;
        }
        break;
    }
    lx->p = p;
}

static token lex_next(lexer *lx)
{
    lex_skip(lx);
    token t = {.kind = T_EOF, .line = lx->line};
    const char *p = lx->p, *end = lx->end;
    if (p >= end)
        return t;
    int c = (unsigned char)*p;
    if (is_ident_start(c)) {
        t.kind = T_IDENT;
        t.s = p;
        while (p < end && is_ident_char((unsigned char)*p))
            p++;
        t.n = (size_t)(p - t.s);
        lx->p = p;
    } else if (is_digit(c) || (c == '.' && end - p >= 2 && is_digit((unsigned char)p[1]))) {
        t.kind = T_NUMBER;
        t.value = lex_number(lx);
    } else if (c == '"') {
        /* A string with backslash escapes; may span lines; ends at EOF when unterminated. */
        t.kind = T_STRING;
        t.s = p + 1;
        for (p++; p < end && *p != '"'; p++) {
            if (*p == '\n')
                lx->line++;
            if (*p == '\\' && end - p >= 2) {
                p++;
                if (*p == '\n')
                    lx->line++;
            }
        }
        t.n = (size_t)(p - t.s);
        if (p >= end)
            note(lx->out, "line %d: unterminated string", t.line);
        else
            p++;
        lx->p = p;
    } else if (c == '#') {
        /* `#name`, spaces and tabs allowed after the `#` */
        const char *q = p + 1;
        while (q < end && (*q == ' ' || *q == '\t'))
            q++;
        if (q < end && is_ident_start((unsigned char)*q)) {
            t.kind = T_DIRECTIVE;
            t.s = q;
            while (q < end && is_ident_char((unsigned char)*q))
                q++;
            t.n = (size_t)(q - t.s);
            lx->p = q;
        } else {
            t.kind = T_PUNCT;
            t.c = c;
            lx->p = p + 1;
        }
    } else {
        t.kind = T_PUNCT;
        t.c = c;
        lx->p = p + 1;
    }
    return t;
}

static int is_word(token t, const char *w)
{
    size_t n = strlen(w);
    return (t.kind == T_IDENT || t.kind == T_DIRECTIVE) && t.n == n && memcmp(t.s, w, n) == 0;
}

static int is_punct(token t, int c) { return t.kind == T_PUNCT && t.c == c; }

/* The next token without consuming it. */
static token lex_peek(const lexer *lx)
{
    lexer copy = *lx;
    return lex_next(&copy);
}

/* ---- literal values (look-aheads on a copy of the lexer) ---- */

/* An arithmetic operator after a literal makes it an expression, not a literal. */
static int is_operator(token t)
{
    return t.kind == T_PUNCT && (t.c == '*' || t.c == '/' || t.c == '+' || t.c == '-' ||
                                 t.c == '.' || t.c == '?');
}

/* A signed literal number starting at `t`: 1 and *v, or 0. */
static int signed_number(lexer *lx, token t, double *v)
{
    double sign = 1;
    if (is_punct(t, '+') || is_punct(t, '-')) {
        sign = t.c == '-' ? -1 : 1;
        t = lex_next(lx);
    }
    if (t.kind != T_NUMBER || !isfinite(t.value)) /* 1e400 is no usable literal */
        return 0;
    *v = sign * t.value;
    return 1;
}

/* `<a, b, c ...>` after its `<` (already read): 3..5 literal components, the first three in
 * c3. 1 when literal. */
static int vector_literal(lexer *lx, double c3[3])
{
    double v[5];
    int n = 0;
    for (;;) {
        if (n == 5)
            return 0;
        if (!signed_number(lx, lex_next(lx), &v[n]))
            return 0;
        n++;
        token t = lex_next(lx);
        if (is_punct(t, '>'))
            break;
        if (!is_punct(t, ','))
            return 0;
    }
    if (n < 3)
        return 0;
    memcpy(c3, v, 3 * sizeof(double));
    return 1;
}

static double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* A literal colour starting at `t`: [color|colour] [rgb|rgbf|rgbt|rgbft|srgb...] then a number
 * (grey) or a vector; not followed by an operator. 1 and linear rgb, or 0 (an identifier,
 * a pattern, an expression). */
static int colour_literal(lexer *lx, token t, double rgb[3])
{
    if (is_word(t, "color") || is_word(t, "colour"))
        t = lex_next(lx);
    int srgb = 0;
    if (is_word(t, "rgb") || is_word(t, "rgbf") || is_word(t, "rgbt") || is_word(t, "rgbft")) {
        t = lex_next(lx);
    } else if (is_word(t, "srgb") || is_word(t, "srgbf") || is_word(t, "srgbt") ||
               is_word(t, "srgbft")) {
        srgb = 1;
        t = lex_next(lx);
    }
    double v;
    if (is_punct(t, '<')) {
        if (!vector_literal(lx, rgb))
            return 0;
    } else if (signed_number(lx, t, &v)) {
        rgb[0] = rgb[1] = rgb[2] = v;
    } else {
        return 0;
    }
    if (is_operator(lex_peek(lx)))
        return 0;
    if (srgb)
        for (int i = 0; i < 3; i++)
            rgb[i] = srgb_to_linear(rgb[i]);
    return 1;
}

static double max3(const double c[3]) { return fmax(c[0], fmax(c[1], c[2])); }

/* After specular / phong / metallic / reflection: is the amount > 0? A non-literal amount
 * (an identifier, an expression, `metallic` alone = 1) counts as > 0.
 * `reflection { MIN, MAX ... }` is > 0 when either colour is. */
static int amount_positive(lexer lx)
{
    token t = lex_next(&lx);
    if (is_word(t, "albedo")) /* 3.7: `specular albedo 0.4` */
        t = lex_next(&lx);
    double c[3];
    if (is_punct(t, '{')) {
        if (!colour_literal(&lx, lex_next(&lx), c) || max3(c) > 0)
            return 1;
        if (!is_punct(lex_next(&lx), ','))
            return 0;
        return !colour_literal(&lx, lex_next(&lx), c) || max3(c) > 0;
    }
    if (is_word(t, "off") || is_word(t, "false") || is_word(t, "no"))
        return 0;
    return !colour_literal(&lx, t, c) || max3(c) > 0;
}

/* After `plane`: `{ NORMAL, H` with NORMAL y, +y or <0, k, 0>, k > 0. 1 and *h (0 when H is
 * not a literal) when the plane faces +y. */
static int plane_faces_up(lexer lx, double *h)
{
    if (!is_punct(lex_next(&lx), '{'))
        return 0;
    token t = lex_next(&lx);
    if (is_punct(t, '+'))
        t = lex_next(&lx);
    if (is_word(t, "y")) {
        /* `y` */
    } else if (is_punct(t, '<')) {
        double n[3];
        if (!vector_literal(&lx, n) || !(n[0] == 0 && n[2] == 0 && n[1] > 0))
            return 0;
    } else {
        return 0;
    }
    if (is_operator(lex_peek(&lx)))
        return 0;
    *h = 0;
    if (is_punct(lex_next(&lx), ',')) {
        double v;
        if (signed_number(&lx, lex_next(&lx), &v) && !is_operator(lex_peek(&lx)))
            *h = v;
    }
    return 1;
}

/* After `box`: `{ CORNER, CORNER`, each a literal vector or number (a number is <k, k, k>).
 * 1 and the two corners when literal. */
static int box_corners(lexer lx, double a[3], double b[3])
{
    if (!is_punct(lex_next(&lx), '{'))
        return 0;
    for (int k = 0; k < 2; k++) {
        double *c = k ? b : a, v;
        token t = lex_next(&lx);
        if (is_punct(t, '<')) {
            if (!vector_literal(&lx, c))
                return 0;
        } else if (signed_number(&lx, t, &v)) {
            c[0] = c[1] = c[2] = v;
        } else {
            return 0;
        }
        if (is_operator(lex_peek(&lx)))
            return 0;
        if (k == 0 && !is_punct(lex_next(&lx), ','))
            return 0;
    }
    return 1;
}

/* Rec. 709 / sRGB luminance; -1 when it overflows. A negative colour (POV-Ray allows it: a
 * pigment that takes light away) is no albedo: read as 0, with a note. */
static double luminance(const lexer *lx, const double c[3])
{
    double y = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    if (!isfinite(y))
        return -1;
    if (y < 0) {
        note(lx->out, "line %d: the ground's colour has luminance %g: read as albedo 0",
             lx->line, y);
        return 0;
    }
    return y;
}

/* After `pigment`: `{ COLOUR` -> its luminance, or -1. */
static double pigment_albedo(lexer lx)
{
    double c[3];
    if (!is_punct(lex_next(&lx), '{') || !colour_literal(&lx, lex_next(&lx), c))
        return -1;
    return luminance(&lx, c);
}

/* After EnvLight_Diffuse_Texture (skip_args 0) or EnvLight_Add_Ambient (skip_args 1):
 * `( [ARG,] COLOUR )` -> its luminance, or -1. */
static double macro_albedo(lexer lx, int skip_args)
{
    if (!is_punct(lex_next(&lx), '('))
        return -1;
    token t = lex_next(&lx);
    if (skip_args) { /* the texture argument: up to the `,` outside brackets, a bounded look */
        int nest = 0;
        for (int i = 0; i < 4096 && !(nest == 0 && is_punct(t, ',')); i++, t = lex_next(&lx)) {
            if (t.kind == T_EOF)
                return -1;
            if (is_punct(t, '(') || is_punct(t, '{') || is_punct(t, '['))
                nest++;
            else if (is_punct(t, ')') || is_punct(t, '}') || is_punct(t, ']'))
                if (--nest < 0)
                    return -1;
        }
        if (!is_punct(t, ','))
            return -1;
        t = lex_next(&lx);
    }
    double c[3];
    if (!colour_literal(&lx, t, c) || !is_punct(lex_next(&lx), ')'))
        return -1;
    return luminance(&lx, c);
}

/* ---- the scan ---- */

/* POV-Ray 3.7's standard includes (Debian's povray-includes) and envlight's own: following them
 * would add nothing a scene places. */
static const char *const STANDARD_INCLUDES[] = {
    "arrays.inc", "chars.inc", "colors.inc", "consts.inc", "debug.inc", "finish.inc",
    "functions.inc", "glass.inc", "glass_old.inc", "golds.inc", "ior.inc", "logo.inc",
    "makegrass.inc", "math.inc", "meshmaker.inc", "metals.inc", "rad_def.inc", "rand.inc",
    "screen.inc", "shapes.inc", "shapes2.inc", "shapes3.inc", "shapes_old.inc", "shapesq.inc",
    "skies.inc", "stage1.inc", "stars.inc", "stdcam.inc", "stdinc.inc", "stoneold.inc",
    "stones.inc", "stones1.inc", "stones2.inc", "strings.inc", "sunpos.inc", "textures.inc",
    "transforms.inc", "woodmaps.inc", "woods.inc", "envlight.inc",
};

static int standard_include(token t)
{
    for (size_t i = 0; i < sizeof STANDARD_INCLUDES / sizeof STANDARD_INCLUDES[0]; i++)
        if (t.kind == T_STRING && t.n == strlen(STANDARD_INCLUDES[i]) &&
            !memcmp(t.s, STANDARD_INCLUDES[i], t.n))
            return 1;
    return 0;
}

static const char *const OBJECT_WORDS[] = {
    "sphere", "box", "plane", "cylinder", "cone", "torus", "disc", "triangle", "smooth_triangle",
    "polygon", "mesh", "mesh2", "union", "merge", "difference", "intersection", "blob",
    "isosurface", "superellipsoid", "lathe", "sor", "prism", "height_field", "text", "object",
    "parametric", "julia_fractal", "bicubic_patch", "quadric", "cubic", "quartic", "poly", "ovus",
    "lemon", "sphere_sweep", "light_group",
};

static int is_object_word(token t)
{
    if (t.kind != T_IDENT)
        return 0;
    for (size_t i = 0; i < sizeof OBJECT_WORDS / sizeof OBJECT_WORDS[0]; i++)
        if (is_word(t, OBJECT_WORDS[i]))
            return 1;
    return 0;
}

enum { F_COND, F_LOOP, F_MACRO };

/* One open #if/#ifdef/#ifndef/#switch (objects and casters before it, the most any closed
 * branch placed), #while/#for, or #macro. */
typedef struct frame {
    int kind;
    int base_objects, base_casters, max_objects, max_casters;
} frame;

#define MAX_FRAMES 256 /* POV-Ray's own conditional stack is 200 deep */

typedef struct scan {
    lexer lx;
    pov_scene *out;
    int depth;           /* brace depth (<= 64 Mi: no overflow) */
    int open_line;       /* line of the outermost open `{` */
    frame frames[MAX_FRAMES];
    int nframes, lost;   /* stored frames; frames nested past the cap (counted only) */
    int macros;          /* #macro frames among the stored ones */
    int decl;            /* inside the value of a #declare / #local */
    int decl_depth;      /* brace depth of its `=` */
    int decl_tokens;     /* tokens of the value so far */
    int decl_level;      /* >= 0: the value is a conditional; it ends when the nesting drops below */
    int stmt;            /* inside a placed top-level object statement */
    int stmt_no_shadow;
    int stmt_transformed; /* the statement has a transform of its own (rotate, scale, ...) */
    int ground_search;   /* looking for the ground plane's (or box's) colour in its block */
    int box_pending;     /* the statement is a box that may be the ground (decided at its end) */
    double box_height, box_area, box_albedo, best_box_area;
    int finish_depth;    /* interior depth of the finish { } being read, -1 outside */
    int finish_reflect, finish_highlight, finish_line;
    int gs_depth;        /* interior depth of global_settings { }, -1 outside */
    int photons_depth;   /* interior depth of photons { } (its `reflection on` is no finish), -1 outside */
} scan;

static int level(const scan *s) { return s->nframes + s->lost; }

/* Closes the current branch of a conditional frame: its count competes for the maximum and
 * the next branch starts again from the base. */
static void close_branch(scan *s, frame *f)
{
    int o = s->out->objects - f->base_objects, c = s->out->casters - f->base_casters;
    if (c > o) /* a statement cut by the branch (broken braces): count it once, not twice */
        c = o;
    if (o > f->max_objects)
        f->max_objects = o;
    if (c > f->max_casters)
        f->max_casters = c;
    s->out->objects = f->base_objects;
    s->out->casters = f->base_casters;
}

static void push(scan *s, int kind, int line)
{
    if (s->nframes == MAX_FRAMES) {
        if (!s->lost)
            note(s->out, "line %d: directives nested deeper than %d", line, MAX_FRAMES);
        s->lost++;
        return;
    }
    frame *f = &s->frames[s->nframes++];
    *f = (frame){.kind = kind, .base_objects = s->out->objects, .base_casters = s->out->casters};
    if (kind == F_MACRO)
        s->macros++;
}

static void pop(scan *s)
{
    if (s->lost) {
        s->lost--;
        return;
    }
    frame *f = &s->frames[--s->nframes];
    if (f->kind == F_MACRO)
        s->macros--;
    if (f->kind == F_COND) {
        close_branch(s, f);
        s->out->objects = f->base_objects + f->max_objects;
        s->out->casters = f->base_casters + f->max_casters;
    }
}

static void end_statement(scan *s)
{
    if (!s->stmt_no_shadow)
        s->out->casters++;
    /* a box is the ground when it has no transform of its own and the largest area so far */
    if (s->box_pending && !s->stmt_transformed && (!s->out->ground || s->out->ground_box) &&
        s->box_area > s->best_box_area) {
        s->best_box_area = s->box_area;
        s->out->ground = s->out->ground_box = 1;
        s->out->ground_height = s->box_height;
        s->out->ground_albedo = s->box_albedo;
    }
    s->stmt = 0;
    s->ground_search = 0;
    s->box_pending = 0;
}

/* A finish block ends: one that reflects and also has highlights is counted. */
static void end_finish(scan *s)
{
    if (s->finish_reflect) {
        s->out->reflective = 1;
        if (s->finish_highlight && !s->out->double_highlights++)
            s->out->double_line = s->finish_line;
    }
    s->finish_depth = -1;
}

/* After `#declare` / `#local`: NAME [ [i] ...] [.field] `=`. Consumes them and opens the
 * declaration when the `=` is there; leaves the lexer alone otherwise. */
static void start_declaration(scan *s)
{
    lexer lx = s->lx;
    token t = lex_next(&lx);
    if (t.kind != T_IDENT)
        return;
    for (int i = 0; i < 64; i++) {
        t = lex_next(&lx);
        if (is_punct(t, '=')) {
            s->lx = lx;
            s->decl = 1;
            s->decl_depth = s->depth;
            s->decl_tokens = 0;
            s->decl_level = -1;
            return;
        }
        if (t.kind == T_EOF || t.kind == T_DIRECTIVE || is_punct(t, '{') || is_punct(t, '}') ||
            is_punct(t, ';'))
            return;
    }
}

static void directive(scan *s, token t)
{
    if (is_word(t, "declare") || is_word(t, "local")) {
        if (!s->decl)
            start_declaration(s);
    } else if (is_word(t, "include")) {
        token name = lex_peek(&s->lx);
        if (!standard_include(name) && !s->out->includes++ && name.kind == T_STRING)
            snprintf(s->out->include_name, sizeof s->out->include_name, "%.*s",
                     (int)(name.n < 127 ? name.n : 127), name.s);
    } else if (is_word(t, "macro")) {
        push(s, F_MACRO, t.line);
        if (lex_peek(&s->lx).kind == T_IDENT) /* its name is no call */
            lex_next(&s->lx);
    } else if (is_word(t, "if") || is_word(t, "ifdef") || is_word(t, "ifndef") ||
               is_word(t, "switch")) {
        push(s, F_COND, t.line);
        if (s->decl && s->decl_level < 0 && s->depth == s->decl_depth && s->decl_tokens == 1)
            s->decl_level = level(s);
    } else if (is_word(t, "while") || is_word(t, "for")) {
        push(s, F_LOOP, t.line);
    } else if (is_word(t, "else") || is_word(t, "elseif") || is_word(t, "case") ||
               is_word(t, "range")) {
        if (!s->lost && s->nframes && s->frames[s->nframes - 1].kind == F_COND)
            close_branch(s, &s->frames[s->nframes - 1]);
    } else if (is_word(t, "end")) {
        if (!level(s)) {
            note(s->out, "line %d: #end without #if, #switch, #while, #for or #macro", t.line);
            return;
        }
        pop(s);
        if (s->decl && s->decl_level >= 0 && level(s) < s->decl_level)
            s->decl = 0;
    }
}

static void identifier(scan *s, token t)
{
    pov_scene *out = s->out;
    token next = lex_peek(&s->lx);
    if (is_object_word(t)) {
        if (s->depth == 0 && !s->decl && !s->macros && !s->lost && !s->stmt && is_punct(next, '{')) {
            out->objects++;
            s->stmt = 1;
            s->stmt_no_shadow = s->stmt_transformed = 0;
            double h, a[3], b[3];
            if ((!out->ground || out->ground_box) && is_word(t, "plane") &&
                plane_faces_up(s->lx, &h)) { /* a plane wins over a box */
                out->ground = 1;
                out->ground_box = 0;
                out->ground_height = h;
                out->ground_albedo = -1;
                s->best_box_area = INFINITY;
                s->ground_search = 1;
            } else if (is_word(t, "box") && box_corners(s->lx, a, b)) {
                double dx = fabs(b[0] - a[0]), dy = fabs(b[1] - a[1]), dz = fabs(b[2] - a[2]);
                if (dx >= 4 * dy && dz >= 4 * dy && dx * dz > 0 && isfinite(dx * dz)) {
                    s->box_pending = s->ground_search = 1;
                    s->box_height = fmax(a[1], b[1]);
                    s->box_area = dx * dz;
                    s->box_albedo = -1;
                }
            }
        }
        return;
    }
    if (is_word(t, "light_source") && is_punct(next, '{') && !s->macros && !s->lost) {
        if (s->decl)
            out->lights_declared++;
        else
            out->lights++;
        return;
    }
    if (s->stmt && s->depth == 1 &&
        (is_word(t, "rotate") || is_word(t, "scale") || is_word(t, "translate") ||
         is_word(t, "matrix") || is_word(t, "transform"))) {
        s->stmt_transformed = 1;
        return;
    }
    if (is_word(t, "no_shadow")) {
        if (s->stmt && s->depth == 1)
            s->stmt_no_shadow = 1;
    } else if (is_word(t, "specular") || is_word(t, "phong") || is_word(t, "metallic") ||
               is_word(t, "reflection")) {
        int in_photons = s->photons_depth >= 0 && s->depth >= s->photons_depth;
        if (!in_photons && amount_positive(s->lx)) {
            out->glossy = 1;
            if (s->finish_depth >= 0 && is_word(t, "reflection"))
                s->finish_reflect = 1;
            else if (s->finish_depth >= 0 && !is_word(t, "metallic"))
                s->finish_highlight = 1;
        }
    } else if (is_word(t, "finish")) {
        if (is_punct(next, '{') && s->finish_depth < 0) {
            s->finish_depth = s->depth + 1;
            s->finish_reflect = s->finish_highlight = 0;
            s->finish_line = t.line;
        }
    } else if (is_word(t, "global_settings")) {
        if (is_punct(next, '{') && s->gs_depth < 0)
            s->gs_depth = s->depth + 1;
    } else if (is_word(t, "photons")) {
        if (is_punct(next, '{') && s->photons_depth < 0)
            s->photons_depth = s->depth + 1;
    } else if (is_word(t, "radiosity")) {
        if (s->gs_depth >= 0 && s->depth >= s->gs_depth)
            out->radiosity = 1;
    } else if (is_word(t, "EnvLight_Radiosity_Settings") ||
               is_word(t, "EnvLight_Radiosity_Residual_Settings")) {
        if (is_punct(next, '('))
            out->radiosity = 1;
    } else if (is_word(t, "background") || is_word(t, "sky_sphere")) {
        out->sky = 1;
    } else if (is_word(t, "EnvLight_Sky")) {
        if (is_punct(next, '('))
            out->sky = 1;
    } else if (s->ground_search && !s->decl) {
        /* the first colour source met in the ground plane's block decides */
        double *albedo = s->box_pending ? &s->box_albedo : &out->ground_albedo;
        if (is_word(t, "pigment") && is_punct(next, '{')) {
            *albedo = pigment_albedo(s->lx);
            s->ground_search = 0;
        } else if (is_word(t, "EnvLight_Diffuse_Texture") && is_punct(next, '(')) {
            *albedo = macro_albedo(s->lx, 0);
            s->ground_search = 0;
        } else if (is_word(t, "EnvLight_Add_Ambient") && is_punct(next, '(')) {
            *albedo = macro_albedo(s->lx, 1);
            s->ground_search = 0;
        }

    }
}

/* Ends the current declaration when `t` is past its value: a `;` at its depth, another
 * directive or statement (`word {`) after some value at its depth. 1 when `t` is consumed. */
static int declaration_end(scan *s, token t)
{
    if (!s->decl || s->decl_level >= 0 || s->depth != s->decl_depth)
        return 0;
    if (is_punct(t, ';')) {
        s->decl = 0;
        return 1;
    }
    if (s->decl_tokens > 0 &&
        (t.kind == T_DIRECTIVE || (t.kind == T_IDENT && is_punct(lex_peek(&s->lx), '{'))))
        s->decl = 0;
    return 0;
}

void pov_scene_scan(const char *text, size_t n, pov_scene *out)
{
    memset(out, 0, sizeof *out);
    out->ground_albedo = -1;
    if (!text) {
        text = "";
        n = 0;
    }
    scan s = {.lx = {.p = text, .end = text + n, .line = 1, .out = out},
              .out = out, .decl_level = -1, .gs_depth = -1, .photons_depth = -1,
              .finish_depth = -1};
    for (;;) {
        token t = lex_next(&s.lx);
        if (t.kind == T_EOF)
            break;
        if (declaration_end(&s, t))
            continue;
        if (s.decl)
            s.decl_tokens++;
        if (t.kind == T_DIRECTIVE) {
            directive(&s, t);
        } else if (t.kind == T_IDENT) {
            identifier(&s, t);
        } else if (is_punct(t, '{')) {
            if (s.depth == 0)
                s.open_line = t.line;
            s.depth++;
        } else if (is_punct(t, '}')) {
            if (s.depth == 0) {
                note(out, "line %d: '}' without a matching '{'", t.line);
                continue;
            }
            s.depth--;
            if (s.decl && s.depth <= s.decl_depth && (s.decl_level < 0 || s.depth < s.decl_depth))
                s.decl = 0;
            if (s.stmt && s.depth == 0)
                end_statement(&s);
            if (s.gs_depth > s.depth)
                s.gs_depth = -1;
            if (s.finish_depth > s.depth)
                end_finish(&s);
            if (s.photons_depth > s.depth)
                s.photons_depth = -1;
        }
    }
    if (s.finish_depth >= 0)
        end_finish(&s);
    if (s.stmt)
        end_statement(&s);
    if (s.depth > 0)
        note(out, "line %d: '{' never closed", s.open_line);
    if (level(&s) > 0)
        note(out, "end of file inside %d #if, #switch, #while, #for or #macro without #end",
             level(&s));
    while (level(&s) > 0)
        pop(&s);
    if (out->casters > out->objects) /* the same, outside conditionals */
        out->casters = out->objects;
}

/* ---- the file ---- */

/* Reads the whole file (a regular file at its size, anything else in chunks) up to the cap. */
/* Whether `name`, an #include of the scene at `path` (relative to its folder, as POV-Ray looks
 * first), is a file envlight wrote: its first line starts "// envlight ". */
static int generated_include(const char *path, const char *name)
{
    char full[4096];
    const char *slash = strrchr(path, '/');
    if (!name[0])
        return 0;
    if (name[0] == '/' || !slash)
        snprintf(full, sizeof full, "%s", name);
    else
        snprintf(full, sizeof full, "%.*s/%s", (int)(slash - path), path, name);
    FILE *f = fopen(full, "rb");
    if (!f)
        return 0;
    char head[12] = {0};
    size_t got = fread(head, 1, sizeof head, f);
    fclose(f);
    return got == sizeof head && !memcmp(head, "// envlight ", sizeof head);
}

int pov_scene_read(const char *path, pov_scene *out)
{
    memset(out, 0, sizeof *out);
    out->ground_albedo = -1;
    if (!path || !path[0]) {
        note(out, "no scene file named");
        return -1;
    }
    FILE *f = fopen(path, "rb");
    if (!f) {
        note(out, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        note(out, "%s: cannot stat: %s", path, strerror(errno));
        fclose(f);
        return -1;
    }
    if (S_ISDIR(st.st_mode)) {
        note(out, "%s: is a directory, not a scene file", path);
        fclose(f);
        return -1;
    }
    if (S_ISREG(st.st_mode) && (unsigned long long)st.st_size > POV_SCENE_MAX_BYTES) {
        note(out, "%s: %lld bytes, more than the %zu MiB a scene may have", path,
             (long long)st.st_size, POV_SCENE_MAX_BYTES >> 20);
        fclose(f);
        return -1;
    }
    size_t cap = S_ISREG(st.st_mode) ? (size_t)st.st_size + 1 : (size_t)1 << 16;
    size_t n = 0;
    char *buf = malloc(cap);
    int too_big = 0;
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break; /* end of file or an error */
        if (n > POV_SCENE_MAX_BYTES) {
            too_big = 1;
            break;
        }
        size_t grown = cap * 2 > POV_SCENE_MAX_BYTES + 1 ? POV_SCENE_MAX_BYTES + 1 : cap * 2;
        char *b = realloc(buf, grown);
        if (!b) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = b;
        cap = grown;
    }
    int failed = ferror(f), err = errno;
    fclose(f);
    if (!buf) {
        note(out, "%s: out of memory reading it", path);
        return -1;
    }
    if (failed || too_big) {
        if (too_big)
            note(out, "%s: more than the %zu MiB a scene may have", path, POV_SCENE_MAX_BYTES >> 20);
        else
            note(out, "%s: cannot read: %s", path, strerror(err));
        free(buf);
        return -1;
    }
    pov_scene_scan(buf, n, out);
    free(buf);
    if (out->includes && generated_include(path, out->include_name)) {
        out->includes--; /* an include envlight wrote (the one being written, or an earlier) */
        out->include_name[0] = 0;
    }
    return 0;
}
