/* Benchmark of the int8 per-DoF networks: all branches of a paper-sized model (6 x (11 -> 256 -> 32 ->
 * 32 -> 1)) per frame, single thread. Prints the MAC count and the median / p90 microseconds per frame.
 *
 *   bench_nn [model.tvonn] [frames]     default: test/data/nn/paper.tvonn of the source tree, 5000 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "tinyvo/nn.h"

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

int main(int argc, char **argv)
{
    char path[4096];
    const char *model = argc > 1 ? argv[1] : NULL;
    int frames = argc > 2 ? atoi(argv[2]) : 5000;
    FILE *fp;
    long size;
    unsigned char *file;
    void *mem;
    size_t need = 0;
    tvo_nn *nn = NULL;
    tvo_status st;
    double *t;
    float feat[TVO_FEAT_COUNT], out[6], sink = 0.0f;
    int i, k;
    if (model == NULL) { /* <src>/test/bench/bench_nn.c -> <src>/test/data/nn/paper.tvonn */
        const char *src = __FILE__;
        const char *cut = strstr(src, "test/bench/bench_nn.c");
        size_t n = cut != NULL ? (size_t)(cut - src) : 0;
        if (n + 64 > sizeof path)
            return 1;
        memcpy(path, src, n);
        strcpy(path + n, "test/data/nn/paper.tvonn");
        model = path;
    }
    if (frames < 10)
        frames = 10;
    fp = fopen(model, "rb");
    if (fp == NULL) {
        fprintf(stderr, "cannot open %s\n", model);
        return 1;
    }
    fseek(fp, 0, SEEK_END);
    size = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    file = (unsigned char *)malloc((size_t)size);
    if (file == NULL || fread(file, 1, (size_t)size, fp) != (size_t)size) {
        fclose(fp);
        return 1;
    }
    fclose(fp);
    st = tvo_nn_required_size(file, (size_t)size, &need);
    if (st != TVO_OK) {
        fprintf(stderr, "%s: %s\n", model, tvo_status_str(st));
        return 1;
    }
    mem = malloc(need);
    t = (double *)malloc(sizeof(double) * (size_t)frames);
    if (mem == NULL || t == NULL || tvo_nn_load(&nn, file, (size_t)size, mem, need) != TVO_OK)
        return 1;
    for (i = 0; i < TVO_FEAT_COUNT; ++i)
        feat[i] = 0.1f * (float)i;
    for (i = 0; i < frames; ++i) {
        double t0;
        feat[i % TVO_FEAT_COUNT] += 0.001f;
        t0 = now_us();
        st = tvo_nn_run(nn, feat, out);
        t[i] = now_us() - t0;
        for (k = 0; k < 6; ++k)
            sink += out[k];
    }
    qsort(t, (size_t)frames, sizeof(double), cmp_d);
    printf("bench_nn: %s\n", model);
    printf("  branches %d, MACs per frame %u, model memory %zu bytes, file %ld bytes\n",
           (int)tvo_nn_branch_count(nn), (unsigned)tvo_nn_macs(nn), need, size);
    printf("  per frame (all branches), %d frames: median %.2f us, p90 %.2f us, min %.2f us (%s)\n", frames,
           t[frames / 2], t[frames * 9 / 10], t[0], st == TVO_OK ? "ok" : "error");
    printf("  %.2f GMAC/s at the median (checksum %g)\n", (double)tvo_nn_macs(nn) / t[frames / 2] * 1e-3,
           (double)sink);
    free(t);
    free(mem);
    free(file);
    return 0;
}
