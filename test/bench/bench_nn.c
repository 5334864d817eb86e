/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark of the int8 per-DoF networks: all branches of a model per frame (tvo_nn_run_all), single
 * thread. Prints per model the MAC count and the median / p90 microseconds per frame, and a checksum of
 * the outputs the model provides (tvo_nn_output_mask: a step-only model's missing DoFs are NaN by
 * contract and are not summed). With several models the frames are interleaved (frame i runs every model
 * once, in the order given) so that all see the same machine load, and each median is also given as a
 * ratio to the first model's.
 *
 *   bench_nn [model.tvonn ...] [frames]     default: test/data/nn/paper.tvonn of the source tree, 5000
 *   (the last argument is the frame count when it is a number) */
#define _POSIX_C_SOURCE 199309L
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "tinyvo/nn.h"

#define MAX_MODELS 8

typedef struct {
    const char *path;
    long size;
    unsigned char *file;
    void *mem;
    size_t need;
    tvo_nn *nn;
    int32_t mask;
    double *t;
    double sink;
    int errors;
} model_run;

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int is_count(const char *s)
{
    if (*s == '\0')
        return 0;
    for (; *s != '\0'; ++s)
        if (!isdigit((unsigned char)*s))
            return 0;
    return 1;
}

static int load(model_run *m, int frames)
{
    FILE *fp = fopen(m->path, "rb");
    tvo_status st;
    if (fp == NULL) {
        fprintf(stderr, "cannot open %s\n", m->path);
        return 1;
    }
    fseek(fp, 0, SEEK_END);
    m->size = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    m->file = m->size > 0 ? (unsigned char *)malloc((size_t)m->size) : NULL;
    if (m->file == NULL || fread(m->file, 1, (size_t)m->size, fp) != (size_t)m->size) {
        fclose(fp);
        fprintf(stderr, "cannot read %s\n", m->path);
        return 1;
    }
    fclose(fp);
    st = tvo_nn_required_size(m->file, (size_t)m->size, &m->need);
    if (st != TVO_OK) {
        fprintf(stderr, "%s: %s\n", m->path, tvo_status_str(st));
        return 1;
    }
    m->mem = malloc(m->need);
    m->t = (double *)malloc(sizeof(double) * (size_t)frames);
    if (m->mem == NULL || m->t == NULL)
        return 1;
    st = tvo_nn_load(&m->nn, m->file, (size_t)m->size, m->mem, m->need);
    if (st != TVO_OK) {
        fprintf(stderr, "%s: %s\n", m->path, tvo_status_str(st));
        return 1;
    }
    m->mask = tvo_nn_output_mask(m->nn);
    return 0;
}

int main(int argc, char **argv)
{
    static const char *const names[TVO_NN_OUT_COUNT] = {"tx", "ty", "tz", "rx", "ry", "rz", "step"};
    char path[4096];
    model_run runs[MAX_MODELS];
    int n_models = 0, frames = 5000, last = argc - 1;
    float feat[TVO_FEAT_COUNT], out[TVO_NN_OUT_COUNT];
    int i, k, j, rc = 0;
    memset(runs, 0, sizeof runs);
    if (last >= 1 && is_count(argv[last]))
        frames = atoi(argv[last--]);
    for (i = 1; i <= last; ++i) {
        if (n_models == MAX_MODELS) {
            fprintf(stderr, "at most %d models\n", MAX_MODELS);
            return 1;
        }
        runs[n_models++].path = argv[i];
    }
    if (n_models == 0) { /* <src>/test/bench/bench_nn.c -> <src>/test/data/nn/paper.tvonn */
        const char *src = __FILE__;
        const char *cut = strstr(src, "test/bench/bench_nn.c");
        size_t n = cut != NULL ? (size_t)(cut - src) : 0;
        if (n + 64 > sizeof path)
            return 1;
        memcpy(path, src, n);
        strcpy(path + n, "test/data/nn/paper.tvonn");
        runs[n_models++].path = path;
    }
    if (frames < 10)
        frames = 10;
    for (j = 0; j < n_models; ++j)
        if (load(&runs[j], frames) != 0)
            return 1;
    for (i = 0; i < TVO_FEAT_COUNT; ++i)
        feat[i] = 0.1f * (float)i;
    for (i = 0; i < frames; ++i) {
        feat[i % TVO_FEAT_COUNT] += 0.001f;
        for (j = 0; j < n_models; ++j) {
            model_run *m = &runs[j];
            double t0 = now_us();
            tvo_status st = tvo_nn_run_all(m->nn, feat, out);
            m->t[i] = now_us() - t0;
            if (st != TVO_OK)
                ++m->errors;
            for (k = 0; k < TVO_NN_OUT_COUNT; ++k)
                if (m->mask & (1 << k))
                    m->sink += (double)out[k];
        }
    }
    for (j = 0; j < n_models; ++j)
        qsort(runs[j].t, (size_t)frames, sizeof(double), cmp_d);
    for (j = 0; j < n_models; ++j) {
        model_run *m = &runs[j];
        printf("bench_nn: %s\n", m->path);
        printf("  branches %d, outputs", (int)tvo_nn_branch_count(m->nn));
        for (k = 0; k < TVO_NN_OUT_COUNT; ++k)
            if (m->mask & (1 << k))
                printf(" %s", names[k]);
        printf(", MACs per frame %u, model memory %zu bytes, file %ld bytes\n", (unsigned)tvo_nn_macs(m->nn),
               m->need, m->size);
        printf("  per frame (all branches), %d frames: median %.2f us, p90 %.2f us, min %.2f us (%s)\n",
               frames, m->t[frames / 2], m->t[frames * 9 / 10], m->t[0], m->errors == 0 ? "ok" : "errors");
        printf("  %.2f GMAC/s at the median (checksum of the provided outputs %.9g)",
               (double)tvo_nn_macs(m->nn) / m->t[frames / 2] * 1e-3, m->sink);
        if (j > 0)
            printf("; median / first model's %.3f", m->t[frames / 2] / runs[0].t[frames / 2]);
        printf("\n");
        if (m->errors != 0)
            rc = 1;
    }
    for (j = 0; j < n_models; ++j) {
        free(runs[j].t);
        free(runs[j].mem);
        free(runs[j].file);
    }
    return rc;
}
