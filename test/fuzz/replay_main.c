/* SPDX-License-Identifier: Apache-2.0 */
/* Replay driver for the fuzz harnesses when libFuzzer is not available (gcc builds, the ASan build of
 * tools/run-tests.sh): runs LLVMFuzzerTestOneInput once on every regular file named on the command
 * line or found (not recursively, in name order) in a directory named there. Exit status 0 when every
 * input ran; a harness whose invariant breaks aborts (and a sanitizer reports its own errors).
 * Usage: fuzz_<name> PATH... */
#define _POSIX_C_SOURCE 200809L
/* 64-bit off_t/ino_t on 32-bit targets: without it readdir() fails with EOVERFLOW on ext4 (64-bit
 * directory offsets), e.g. armhf under qemu-arm on a 64-bit host, and no corpus file is found. */
#define _FILE_OFFSET_BITS 64
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz_common.h"

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    uint8_t *buf = NULL;
    size_t cap = 0, len = 0, got;
    if (f == NULL) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return -1;
    }
    do {
        if (len == cap) {
            size_t ncap = cap == 0 ? 4096 : 2 * cap;
            uint8_t *nb = (uint8_t *)realloc(buf, ncap);
            if (nb == NULL) {
                free(buf);
                fclose(f);
                fprintf(stderr, "replay: out of memory reading %s\n", path);
                return -1;
            }
            buf = nb;
            cap = ncap;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
    } while (got > 0);
    if (ferror(f)) {
        fprintf(stderr, "replay: read error on %s\n", path);
        free(buf);
        fclose(f);
        return -1;
    }
    fclose(f);
    /* an exact-size copy, so that ASan sees reads past the end of the input as libFuzzer would */
    {
        uint8_t *in = (uint8_t *)malloc(len > 0 ? len : 1);
        if (in == NULL) {
            free(buf);
            return -1;
        }
        if (len > 0)
            memcpy(in, buf, len);
        free(buf);
        LLVMFuzzerTestOneInput(in, len);
        free(in);
    }
    return 0;
}

static int cmp_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int run_dir(const char *dir, int *count)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char **names = NULL;
    size_t n = 0, cap = 0, i;
    int rc = 0;
    if (d == NULL) {
        fprintf(stderr, "replay: cannot open folder %s\n", dir);
        return -1;
    }
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue; /* ".", "..", hidden files (editor droppings) */
        if (n == cap) {
            size_t ncap = cap == 0 ? 64 : 2 * cap;
            char **nn = (char **)realloc(names, ncap * sizeof *names);
            if (nn == NULL) {
                rc = -1;
                break;
            }
            names = nn;
            cap = ncap;
        }
        names[n] = (char *)malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (names[n] == NULL) {
            rc = -1;
            break;
        }
        sprintf(names[n], "%s/%s", dir, e->d_name);
        ++n;
    }
    closedir(d);
    if (n > 1)
        qsort(names, n, sizeof *names, cmp_names);
    for (i = 0; i < n; ++i) {
        struct stat sb;
        if (rc == 0 && stat(names[i], &sb) == 0 && S_ISREG(sb.st_mode)) {
            if (run_file(names[i]) != 0)
                rc = -1;
            else
                ++*count;
        }
        free(names[i]);
    }
    free(names);
    return rc;
}

int main(int argc, char **argv)
{
    int count = 0, rc = 0;
    if (argc < 2) {
        fprintf(stderr, "usage: %s FILE_OR_FOLDER...\n", argv[0]);
        return 2;
    }
    for (int i = 1; i < argc && rc == 0; ++i) {
        struct stat sb;
        if (stat(argv[i], &sb) != 0) {
            fprintf(stderr, "replay: no such file or folder: %s\n", argv[i]);
            rc = -1;
        } else if (S_ISDIR(sb.st_mode)) {
            rc = run_dir(argv[i], &count);
        } else if (run_file(argv[i]) == 0) {
            ++count;
        } else {
            rc = -1;
        }
    }
    if (rc == 0 && count == 0) {
        fprintf(stderr, "replay: no input files found\n");
        rc = -1;
    }
    printf("replay: %d input(s) ran without a failure\n", count);
    return rc == 0 ? 0 : 1;
}
