// SPDX-License-Identifier: BSD-2-Clause
/* STREAM-like triad a = b + s c on arrays far larger than the caches:
 * the memory bandwidth that bounds a sparse matrix-vector product.
 * Prints the best of 10 repetitions in GB/s (24 bytes per element moved:
 * two loads and one store; write-allocate traffic not counted, as in STREAM).
 * Usage: triad [n_elements]   (default 2^25 = 33.5 M, 805 MB in all) */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(int argc, char **argv) {
  size_t n = argc > 1 ? (size_t)atol(argv[1]) : (size_t)1 << 25;
  double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *c = malloc(n * sizeof *c);
  if (!a || !b || !c) { fprintf(stderr, "triad: out of memory\n"); return 1; }
  for (size_t i = 0; i < n; i++) { a[i] = 0.0; b[i] = 1.0; c[i] = 2.0; }
  double best = 1e30, s = 3.0;
  for (int r = 0; r < 10; r++) {
    double t0 = now();
    for (size_t i = 0; i < n; i++) a[i] = b[i] + s * c[i];
    double t = now() - t0;
    if (t < best) best = t;
  }
  double check = 0.0;
  for (size_t i = 0; i < n; i += 4096) check += a[i];
  printf("%.2f\n", 24.0 * n / best / 1e9);
  fprintf(stderr, "triad: n = %zu, best %.4f s, checksum %g\n", n, best, check);
  free(a); free(b); free(c);
  return 0;
}
