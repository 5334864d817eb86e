/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port, internal: the YAML subset of the sensor.yaml and calibration readers (see tvo_yaml.h). */
#include "tvo_yaml.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Upper bounds that keep a hostile input's cost linear-ish: keys per document (the duplicate check
 * is quadratic in the keys of one mapping), nesting depth, key length. Calibration files have well
 * under a hundred keys. */
#define TVO_YAML_MAX_NODES 4096
#define TVO_YAML_MAX_DEPTH 32
#define TVO_YAML_MAX_KEY 255

static void tvo_yaml_err(char *err, size_t err_size, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    if (err != NULL && err_size > 0)
        vsnprintf(err, err_size, fmt, ap);
    va_end(ap);
}

static int tvo_yaml_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r';
}

static void tvo_yaml_trim(const char **b, const char **e)
{
    while (*b < *e && tvo_yaml_blank(**b))
        ++*b;
    while (*e > *b && tvo_yaml_blank((*e)[-1]))
        --*e;
}

static int tvo_yaml_span_eq(const char *b, const char *e, const char *s)
{
    size_t n = strlen(s);
    return (size_t)(e - b) == n && memcmp(b, s, n) == 0;
}

/* End of the non-comment part of a line: a '#' at the start or after a blank starts a comment
 * (outside quotes). */
static const char *tvo_yaml_uncomment(const char *b, const char *e)
{
    const char *p;
    char quote = 0;
    for (p = b; p < e; ++p) {
        if (quote) {
            if (*p == quote)
                quote = 0;
        } else if (*p == '"' || *p == '\'') {
            quote = *p;
        } else if (*p == '#' && (p == b || tvo_yaml_blank(p[-1]))) {
            return p;
        }
    }
    return e;
}

/* ---- arena and nodes ----------------------------------------------------------------------------- */

static int tvo_yaml_put(tvo_yaml_doc *d, const char *b, size_t n)
{
    if (d->used + n + 1 > d->size) {
        size_t ns = d->size == 0 ? 4096 : d->size;
        char *na;
        while (ns < d->used + n + 1)
            ns *= 2;
        na = (char *)realloc(d->arena, ns);
        if (na == NULL)
            return 0;
        d->arena = na;
        d->size = ns;
    }
    if (n > 0)
        memcpy(d->arena + d->used, b, n);
    d->used += n;
    return 1;
}

static int tvo_yaml_put_nul(tvo_yaml_doc *d)
{
    static const char z = '\0';
    return tvo_yaml_put(d, &z, 1);
}

static int tvo_yaml_new_node(tvo_yaml_doc *d)
{
    if (d->count == d->cap) {
        int nc = d->cap == 0 ? 32 : d->cap * 2;
        tvo_yaml_node *nn = (tvo_yaml_node *)realloc(d->node, (size_t)nc * sizeof *nn);
        if (nn == NULL)
            return -1;
        d->node = nn;
        d->cap = nc;
    }
    memset(&d->node[d->count], 0, sizeof d->node[0]);
    return d->count++;
}

void tvo_yaml_free(tvo_yaml_doc *doc)
{
    if (doc == NULL)
        return;
    free(doc->node);
    free(doc->arena);
    memset(doc, 0, sizeof *doc);
}

const char *tvo_yaml_key(const tvo_yaml_doc *doc, int i)
{
    return doc->arena + doc->node[i].kbeg;
}

const char *tvo_yaml_value(const tvo_yaml_doc *doc, int i)
{
    return doc->arena + doc->node[i].vbeg;
}

static int tvo_yaml_ieq(const char *a, const char *b)
{
    for (;; ++a, ++b) {
        char x = *a, y = *b;
        if (x >= 'A' && x <= 'Z')
            x = (char)(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z')
            y = (char)(y - 'A' + 'a');
        if (x != y)
            return 0;
        if (x == '\0')
            return 1;
    }
}

int tvo_yaml_find(const tvo_yaml_doc *doc, int parent, const char *key, int icase)
{
    int i;
    for (i = 0; i < doc->count; ++i) {
        const char *k = doc->arena + doc->node[i].kbeg;
        if (doc->node[i].parent == parent && (icase ? tvo_yaml_ieq(k, key) : strcmp(k, key) == 0))
            return i;
    }
    return -1;
}

int tvo_yaml_is(const tvo_yaml_doc *doc, int i, const char *s)
{
    return strcmp(doc->arena + doc->node[i].vbeg, s) == 0;
}

/* ---- numbers ------------------------------------------------------------------------------------ */

int tvo_yaml_parse_double(const char *b, const char *e, double *out)
{
    char buf[64];
    char *end = NULL;
    size_t n = (size_t)(e - b), i;
    double v;
    if (n == 0 || n >= sizeof buf)
        return 0;
    memcpy(buf, b, n);
    buf[n] = '\0';
    /* strtod accepts "inf", "nan", hex floats and leading blanks: allow only a plain decimal number. */
    for (i = 0; i < n; ++i) {
        char c = buf[i];
        if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E'))
            return 0;
    }
    errno = 0;
    v = strtod(buf, &end);
    if (end != buf + n || !isfinite(v) || errno == ERANGE)
        return 0;
    *out = v;
    return 1;
}

int tvo_yaml_scalar_double(const tvo_yaml_doc *doc, int i, double *out)
{
    const char *b = doc->arena + doc->node[i].vbeg, *e = b + doc->node[i].vlen;
    tvo_yaml_trim(&b, &e);
    return tvo_yaml_parse_double(b, e, out);
}

tvo_status tvo_yaml_numbers(const tvo_yaml_doc *doc, int i, double *out, int max, int *n, char *err,
                            size_t err_size)
{
    const tvo_yaml_node *nd = &doc->node[i];
    const char *key = doc->arena + nd->kbeg;
    const char *b = doc->arena + nd->vbeg, *e = b + nd->vlen, *p;
    int count = 0;
    char prev;
    tvo_yaml_trim(&b, &e);
    if (e - b < 2 || *b != '[' || e[-1] != ']') {
        tvo_yaml_err(err, err_size, "line %d: %s: expected a list [..]", nd->line, key);
        return TVO_ERR_FORMAT;
    }
    /* runs of text between the delimiters '[' ']' ',' are numbers; an empty run next to a ',' is an
     * empty element ("[1,,2]", "[,1]", "[1,]") */
    prev = '[';
    p = b + 1;
    while (p <= e - 1) {
        const char *s = p, *tb, *te;
        char next;
        while (p < e - 1 && *p != '[' && *p != ']' && *p != ',')
            ++p;
        next = (p < e - 1) ? *p : ']';
        tb = s;
        te = p;
        tvo_yaml_trim(&tb, &te);
        if (tb == te) {
            if ((prev == ',' && next != '[') || (next == ',' && prev != ']')) {
                tvo_yaml_err(err, err_size, "line %d: %s: bad number ''", nd->line, key);
                return TVO_ERR_FORMAT;
            }
        } else {
            if (prev == ']' || next == '[') {
                tvo_yaml_err(err, err_size, "line %d: %s: bad number '%.*s'", nd->line, key,
                             (int)((te - tb) > 40 ? 40 : (te - tb)), tb);
                return TVO_ERR_FORMAT;
            }
            if (count >= max) {
                tvo_yaml_err(err, err_size, "line %d: %s: more than %d values", nd->line, key, max);
                return TVO_ERR_FORMAT;
            }
            if (!tvo_yaml_parse_double(tb, te, &out[count])) {
                tvo_yaml_err(err, err_size, "line %d: %s: bad number '%.*s'", nd->line, key,
                             (int)((te - tb) > 40 ? 40 : (te - tb)), tb);
                return TVO_ERR_FORMAT;
            }
            ++count;
        }
        prev = next;
        ++p;
    }
    *n = count;
    return TVO_OK;
}

/* ---- the parser --------------------------------------------------------------------------------- */

typedef struct tvo_yaml_lines {
    const char *p, *stop;
    int line;
} tvo_yaml_lines;

static int tvo_yaml_next_line(tvo_yaml_lines *it, const char **beg, const char **end)
{
    const char *e;
    if (it->p >= it->stop)
        return 0;
    *beg = it->p;
    e = it->p;
    while (e < it->stop && *e != '\n')
        ++e;
    it->p = (e < it->stop) ? e + 1 : e;
    it->line++;
    while (e > *beg && e[-1] == '\r')
        --e;
    *end = e;
    return 1;
}

/* Bracket depth after scanning [b, e) from depth *depth ('[' and '{' open, ']' and '}' close, quotes
 * skipped). Returns the position just after the bracket that brought the depth to 0, or NULL. */
static const char *tvo_yaml_scan_flow(const char *b, const char *e, int *depth, char *quote)
{
    const char *p;
    for (p = b; p < e; ++p) {
        if (*quote) {
            if (*p == *quote)
                *quote = 0;
        } else if (*p == '"' || *p == '\'') {
            *quote = *p;
        } else if (*p == '[' || *p == '{') {
            ++*depth;
        } else if (*p == ']' || *p == '}') {
            if (--*depth == 0)
                return p + 1;
        }
    }
    return NULL;
}

/* The first ':' followed by a blank or the end, outside quotes and brackets, or NULL. */
static const char *tvo_yaml_colon(const char *b, const char *e)
{
    const char *q;
    char quote = 0;
    int depth = 0;
    for (q = b; q < e; ++q) {
        if (quote) {
            if (*q == quote)
                quote = 0;
        } else if (*q == '"' || *q == '\'') {
            quote = *q;
        } else if (*q == '[' || *q == '{') {
            ++depth;
        } else if (*q == ']' || *q == '}') {
            --depth;
        } else if (*q == ':' && depth == 0 && (q + 1 == e || tvo_yaml_blank(q[1]))) {
            return q;
        }
    }
    return NULL;
}

static void tvo_yaml_unquote(const char **vb, const char **ve)
{
    if (*ve - *vb >= 2 && (**vb == '"' || **vb == '\'') && (*ve)[-1] == **vb) {
        ++*vb;
        --*ve;
    }
}

/* A new key node under parent with key [kb, ke); duplicate keys of one mapping are refused. */
static int tvo_yaml_add_key(tvo_yaml_doc *d, int parent, const char *kb, const char *ke, int line, int indent,
                            char *err, size_t err_size, tvo_status *st)
{
    int i, k;
    tvo_yaml_unquote(&kb, &ke);
    if (kb == ke || (size_t)(ke - kb) > TVO_YAML_MAX_KEY || *kb == '-' || *kb == '[' || *kb == '{' ||
        *kb == '?' || memchr(kb, '\0', (size_t)(ke - kb)) != NULL) {
        tvo_yaml_err(err, err_size, "line %d: bad key", line);
        *st = TVO_ERR_FORMAT;
        return -1;
    }
    if (d->count >= TVO_YAML_MAX_NODES) {
        tvo_yaml_err(err, err_size, "line %d: too many keys (more than %d)", line, TVO_YAML_MAX_NODES);
        *st = TVO_ERR_FORMAT;
        return -1;
    }
    for (k = 0; k < d->count; ++k) {
        const char *o = d->arena + d->node[k].kbeg;
        if (d->node[k].parent == parent && strlen(o) == (size_t)(ke - kb) &&
            memcmp(o, kb, (size_t)(ke - kb)) == 0) {
            tvo_yaml_err(err, err_size, "line %d: duplicate key '%.*s'", line, (int)(ke - kb), kb);
            *st = TVO_ERR_FORMAT;
            return -1;
        }
    }
    i = tvo_yaml_new_node(d);
    if (i < 0 || !tvo_yaml_put(d, kb, (size_t)(ke - kb)) || !tvo_yaml_put_nul(d)) {
        tvo_yaml_err(err, err_size, "out of memory");
        *st = TVO_ERR_NO_MEMORY;
        return -1;
    }
    d->node[i].parent = parent;
    d->node[i].kbeg = d->used - (size_t)(ke - kb) - 1;
    d->node[i].line = line;
    d->node[i].indent = indent;
    d->node[i].vbeg = d->used - 1; /* the key's NUL: an empty value until one is set */
    if (parent >= 0)
        d->node[parent].nchild++;
    return i;
}

/* Node i's value "{k: v, ...}" (complete, in the arena) becomes child nodes; i becomes a mapping. */
static tvo_status tvo_yaml_expand_flow_map(tvo_yaml_doc *d, int i, char *err, size_t err_size)
{
    /* copy the text out first: adding nodes appends to (and may move) the arena */
    const int line = d->node[i].line;
    size_t n = d->node[i].vlen;
    char *t = (char *)malloc(n + 1);
    const char *b, *e, *p;
    tvo_status st = TVO_OK;
    if (t == NULL) {
        tvo_yaml_err(err, err_size, "out of memory");
        return TVO_ERR_NO_MEMORY;
    }
    memcpy(t, d->arena + d->node[i].vbeg, n);
    t[n] = '\0';
    d->node[i].vbeg = d->node[i].kbeg + strlen(d->arena + d->node[i].kbeg); /* the key's NUL: empty */
    d->node[i].vlen = 0;
    b = t;
    e = t + n;
    tvo_yaml_trim(&b, &e);
    ++b; /* '{' ... '}' */
    --e;
    p = b;
    while (p < e) {
        const char *s = p, *q, *kb, *ke, *vb, *ve, *c;
        int depth = 0, c_idx;
        char quote = 0;
        for (q = p; q < e; ++q) {
            if (quote) {
                if (*q == quote)
                    quote = 0;
            } else if (*q == '"' || *q == '\'') {
                quote = *q;
            } else if (*q == '[' || *q == '{') {
                ++depth;
            } else if (*q == ']' || *q == '}') {
                --depth;
            } else if (*q == ',' && depth == 0) {
                break;
            }
        }
        p = q + 1;
        kb = s;
        ke = q;
        tvo_yaml_trim(&kb, &ke);
        if (kb == ke) {
            if (q == e && s != b)
                break; /* a trailing ',' */
            tvo_yaml_err(err, err_size, "line %d: empty entry in a flow mapping", line);
            st = TVO_ERR_FORMAT;
            break;
        }
        c = tvo_yaml_colon(kb, ke);
        if (c == NULL) {
            tvo_yaml_err(err, err_size, "line %d: expected 'key: value' in a flow mapping", line);
            st = TVO_ERR_FORMAT;
            break;
        }
        vb = c + 1;
        ve = ke;
        ke = c;
        tvo_yaml_trim(&kb, &ke);
        tvo_yaml_trim(&vb, &ve);
        if (vb < ve && *vb == '{') {
            tvo_yaml_err(err, err_size, "line %d: nested flow mappings are not supported", line);
            st = TVO_ERR_FORMAT;
            break;
        }
        tvo_yaml_unquote(&vb, &ve);
        c_idx = tvo_yaml_add_key(d, i, kb, ke, line, d->node[i].indent + 1, err, err_size, &st);
        if (c_idx < 0)
            break;
        d->node[c_idx].vbeg = d->used;
        d->node[c_idx].vlen = (size_t)(ve - vb);
        if (!tvo_yaml_put(d, vb, (size_t)(ve - vb)) || !tvo_yaml_put_nul(d)) {
            tvo_yaml_err(err, err_size, "out of memory");
            st = TVO_ERR_NO_MEMORY;
            break;
        }
    }
    free(t);
    return st;
}

tvo_status tvo_yaml_load(tvo_yaml_doc *d, const char *text, size_t len, char *err, size_t err_size)
{
    static const char sep[] = ", ";
    tvo_yaml_lines it;
    const char *b, *e;
    int stack[TVO_YAML_MAX_DEPTH], child_indent[TVO_YAML_MAX_DEPTH];
    int top = 0;         /* entries on stack */
    int top_indent = -1; /* column of the top-level keys */
    int flow = -1;       /* node whose flow value continues on the next line */
    int flow_item = 0;   /* ... as an item of a block sequence (the sequence stays open) */
    int flow_depth = 0;
    char flow_quote = 0;
    int seq = -1; /* node whose block sequence is open ("[" written) */
    tvo_status st = TVO_OK;
    memset(d, 0, sizeof *d);
    if (text == NULL)
        len = 0;
    if (!tvo_yaml_put_nul(d)) { /* offset 0: an empty string */
        tvo_yaml_err(err, err_size, "out of memory");
        return TVO_ERR_NO_MEMORY;
    }
    it.p = text;
    it.stop = text + len;
    it.line = 0;
    while (tvo_yaml_next_line(&it, &b, &e)) {
        const char *p, *colon, *kb, *ke, *vb, *ve;
        int indent = 0, parent, node;
        if (memchr(b, '\0', (size_t)(e - b)) != NULL) {
            tvo_yaml_err(err, err_size, "line %d: NUL byte", it.line);
            return TVO_ERR_FORMAT;
        }
        e = tvo_yaml_uncomment(b, e);
        if (flow >= 0) { /* continuation of a flow collection */
            const char *close = tvo_yaml_scan_flow(b, e, &flow_depth, &flow_quote);
            if (close != NULL) {
                const char *rest = close;
                tvo_yaml_trim(&rest, &e);
                if (rest != e) {
                    tvo_yaml_err(err, err_size, "line %d: text after '%c'", it.line, close[-1]);
                    return TVO_ERR_FORMAT;
                }
                e = close;
            }
            if (!tvo_yaml_put(d, " ", 1) || !tvo_yaml_put(d, b, (size_t)(e - b))) {
                tvo_yaml_err(err, err_size, "out of memory");
                return TVO_ERR_NO_MEMORY;
            }
            if (close != NULL) {
                if (!flow_item) {
                    d->node[flow].vlen = d->used - d->node[flow].vbeg;
                    if (!tvo_yaml_put_nul(d)) {
                        tvo_yaml_err(err, err_size, "out of memory");
                        return TVO_ERR_NO_MEMORY;
                    }
                    if (d->arena[d->node[flow].vbeg] == '{') {
                        st = tvo_yaml_expand_flow_map(d, flow, err, err_size);
                        if (st != TVO_OK)
                            return st;
                    }
                }
                flow = -1;
            }
            continue;
        }
        while (b + indent < e && b[indent] == ' ')
            ++indent;
        if (b + indent < e && b[indent] == '\t') {
            tvo_yaml_err(err, err_size, "line %d: tab in indentation", it.line);
            return TVO_ERR_FORMAT;
        }
        p = b + indent;
        tvo_yaml_trim(&p, &e);
        if (p == e || *p == '%' || tvo_yaml_span_eq(p, e, "---") || tvo_yaml_span_eq(p, e, "..."))
            continue;

        if (*p == '-' && (p + 1 == e || tvo_yaml_blank(p[1]))) { /* a block-sequence item */
            const char *ib = p + 1, *ie = e;
            tvo_yaml_trim(&ib, &ie);
            while (top > 0 && d->node[stack[top - 1]].indent > indent)
                --top;
            if (top == 0) {
                tvo_yaml_err(err, err_size, "line %d: sequence item outside a mapping", it.line);
                return TVO_ERR_FORMAT;
            }
            node = stack[top - 1];
            if (d->node[node].nchild > 0 || (seq != node && d->node[node].nitems > 0)) {
                tvo_yaml_err(err, err_size, "line %d: sequence item inside a mapping", it.line);
                return TVO_ERR_FORMAT;
            }
            if (ib == ie || *ib == '{' || (*ib == '-' && (ib + 1 == ie || tvo_yaml_blank(ib[1]))) ||
                (*ib != '[' && *ib != '"' && *ib != '\'' && tvo_yaml_colon(ib, ie) != NULL)) {
                tvo_yaml_err(err, err_size,
                             "line %d: only scalars and flow sequences are supported as "
                             "sequence items",
                             it.line);
                return TVO_ERR_FORMAT;
            }
            if (seq != node) {
                if (seq >= 0) { /* a sequence of another key ends here */
                    if (!tvo_yaml_put(d, "]", 1))
                        goto nomem;
                    d->node[seq].vlen = d->used - d->node[seq].vbeg;
                    if (!tvo_yaml_put_nul(d))
                        goto nomem;
                }
                seq = node;
                d->node[node].vbeg = d->used;
                if (!tvo_yaml_put(d, "[", 1))
                    goto nomem;
            } else if (!tvo_yaml_put(d, sep, 2)) {
                goto nomem;
            }
            d->node[node].nitems++;
            tvo_yaml_unquote(&ib, &ie);
            if (*ib == '[') {
                const char *close;
                flow_depth = 0;
                flow_quote = 0;
                close = tvo_yaml_scan_flow(ib, ie, &flow_depth, &flow_quote);
                if (close == NULL) {
                    flow = node;
                    flow_item = 1;
                } else if (close != ie) {
                    tvo_yaml_err(err, err_size, "line %d: text after ']'", it.line);
                    return TVO_ERR_FORMAT;
                }
            }
            if (!tvo_yaml_put(d, ib, (size_t)(ie - ib)))
                goto nomem;
            continue;
        }

        colon = tvo_yaml_colon(p, e);
        if (colon == NULL) {
            tvo_yaml_err(err, err_size, "line %d: expected 'key: value'", it.line);
            return TVO_ERR_FORMAT;
        }
        if (seq >= 0) { /* a key line closes the open block sequence */
            if (!tvo_yaml_put(d, "]", 1))
                goto nomem;
            d->node[seq].vlen = d->used - d->node[seq].vbeg;
            if (!tvo_yaml_put_nul(d))
                goto nomem;
            seq = -1;
        }
        kb = p;
        ke = colon;
        tvo_yaml_trim(&kb, &ke);
        vb = colon + 1;
        ve = e;
        tvo_yaml_trim(&vb, &ve);
        while (top > 0 && d->node[stack[top - 1]].indent >= indent)
            --top;
        if (top == 0) {
            if (top_indent < 0)
                top_indent = indent;
            if (indent != top_indent) {
                tvo_yaml_err(err, err_size, "line %d: indented key outside a mapping", it.line);
                return TVO_ERR_FORMAT;
            }
            parent = -1;
        } else {
            parent = stack[top - 1];
            if (d->node[parent].nitems > 0) {
                tvo_yaml_err(err, err_size, "line %d: key inside a sequence", it.line);
                return TVO_ERR_FORMAT;
            }
            if (d->node[parent].nchild == 0) {
                child_indent[top - 1] = indent;
            } else if (child_indent[top - 1] != indent) {
                tvo_yaml_err(err, err_size, "line %d: indentation does not match the keys above", it.line);
                return TVO_ERR_FORMAT;
            }
        }
        node = tvo_yaml_add_key(d, parent, kb, ke, it.line, indent, err, err_size, &st);
        if (node < 0)
            return st;
        if (vb < ve && *vb == '!') { /* a tag: "!!opencv-matrix" alone, or before a scalar */
            const char *t = vb;
            while (t < ve && !tvo_yaml_blank(*t))
                ++t;
            vb = t;
            tvo_yaml_trim(&vb, &ve);
            if (vb == ve)
                d->node[node].tagged = 1;
        }
        if (vb == ve) { /* a mapping or a block sequence may follow */
            if (top == TVO_YAML_MAX_DEPTH) {
                tvo_yaml_err(err, err_size, "line %d: nesting deeper than %d levels", it.line,
                             TVO_YAML_MAX_DEPTH);
                return TVO_ERR_FORMAT;
            }
            stack[top++] = node;
            continue;
        }
        if (*vb == '|' || *vb == '>') {
            tvo_yaml_err(err, err_size, "line %d: block scalars ('|', '>') are not supported", it.line);
            return TVO_ERR_FORMAT;
        }
        tvo_yaml_unquote(&vb, &ve);
        d->node[node].vbeg = d->used;
        if (!tvo_yaml_put(d, vb, (size_t)(ve - vb)))
            goto nomem;
        if (*vb == '[' || *vb == '{') {
            const char *close;
            flow_depth = 0;
            flow_quote = 0;
            close = tvo_yaml_scan_flow(vb, ve, &flow_depth, &flow_quote);
            if (close == NULL) {
                flow = node;
                flow_item = 0;
                continue;
            }
            if (close != ve) {
                tvo_yaml_err(err, err_size, "line %d: text after '%c'", it.line, close[-1]);
                return TVO_ERR_FORMAT;
            }
        }
        d->node[node].vlen = d->used - d->node[node].vbeg;
        if (!tvo_yaml_put_nul(d))
            goto nomem;
        if (*vb == '{') {
            st = tvo_yaml_expand_flow_map(d, node, err, err_size);
            if (st != TVO_OK)
                return st;
        }
    }
    if (flow >= 0) {
        tvo_yaml_err(err, err_size, "line %d: '[' of '%s' never closed", d->node[flow].line,
                     d->arena + d->node[flow].kbeg);
        return TVO_ERR_FORMAT;
    }
    if (seq >= 0) {
        if (!tvo_yaml_put(d, "]", 1))
            goto nomem;
        d->node[seq].vlen = d->used - d->node[seq].vbeg;
        if (!tvo_yaml_put_nul(d))
            goto nomem;
    }
    return TVO_OK;
nomem:
    tvo_yaml_err(err, err_size, "out of memory");
    return TVO_ERR_NO_MEMORY;
}
