/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port, internal: the YAML subset shared by the sensor.yaml and calibration readers
 * (tvo_euroc.c, tvo_calib.c). Not installed; not part of the public API.
 *
 * Accepted: "key: value" lines nested by indentation (spaces only), block sequences ("- item" lines,
 * each item a scalar or a flow sequence), flow sequences "[a, [b, c], ...]" and flow mappings
 * "{k: v, k2: [..]}" that may span lines, '#' comments, '%' directives, "---"/"..." markers, quoted
 * scalars, and a tag on a mapping's line ("camera_matrix: !!opencv-matrix"). Not accepted (an error
 * naming the line): tabs in indentation, block scalars ('|', '>'), mappings inside block sequences,
 * duplicate keys in one mapping, unbalanced brackets, indentation that fits no open mapping.
 *
 * Every key becomes a node; a node holds either a scalar/flow value (its text, comments removed and
 * continuation lines joined with a blank) or children (a mapping) or block-sequence items (their
 * texts joined into one flow sequence "[i1, i2, ...]"). Memory: heap, about 2 x the input plus 48
 * bytes per key; tvo_yaml_free releases it. */
#ifndef TVO_PORT_YAML_H
#define TVO_PORT_YAML_H

#include <stddef.h>
#include "tinyvo/status.h"

typedef struct tvo_yaml_node {
    int parent;  /* index of the parent node, -1 at top level */
    size_t kbeg; /* key text in tvo_yaml_doc.arena, NUL-terminated */
    size_t vbeg; /* value text in the arena, NUL-terminated (empty for a mapping) */
    size_t vlen;
    int line;   /* 1-based line of the key */
    int indent; /* column of the key */
    int nchild; /* child keys (mapping) */
    int nitems; /* block-sequence items */
    int tagged; /* the key's line carried a tag ("!!opencv-matrix", ...) instead of a value */
} tvo_yaml_node;

typedef struct tvo_yaml_doc {
    tvo_yaml_node *node;
    int count, cap;
    char *arena;
    size_t used, size;
} tvo_yaml_doc;

/* Parse text[0..len) (no NUL terminator needed). TVO_OK, TVO_ERR_FORMAT ("line N: what" in err),
 * TVO_ERR_NO_MEMORY. The document must be freed with tvo_yaml_free whatever the status. */
tvo_status tvo_yaml_load(tvo_yaml_doc *doc, const char *text, size_t len, char *err, size_t err_size);
void tvo_yaml_free(tvo_yaml_doc *doc);

const char *tvo_yaml_key(const tvo_yaml_doc *doc, int i);
const char *tvo_yaml_value(const tvo_yaml_doc *doc, int i);
/* The child of parent (-1: top level) named key, or -1. icase: ASCII case-insensitive match. */
int tvo_yaml_find(const tvo_yaml_doc *doc, int parent, const char *key, int icase);
/* 1 when node i's value is exactly s (case-sensitive). */
int tvo_yaml_is(const tvo_yaml_doc *doc, int i, const char *s);

/* The numbers of node i's value, a flow sequence (nested brackets are flattened: "[[1, 2], [3]]" is
 * 1 2 3), into out[0..max); *n = count. A message "line L: key: ..." on a non-list, a bad number or
 * more than max values. */
tvo_status tvo_yaml_numbers(const tvo_yaml_doc *doc, int i, double *out, int max, int *n, char *err,
                            size_t err_size);
/* A finite plain decimal number from exactly the text [b, e). */
int tvo_yaml_parse_double(const char *b, const char *e, double *out);
/* A scalar node's value as a finite number (1) or not (0). */
int tvo_yaml_scalar_double(const tvo_yaml_doc *doc, int i, double *out);

#endif /* TVO_PORT_YAML_H */
