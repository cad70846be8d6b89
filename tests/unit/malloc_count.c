/* SPDX-License-Identifier: BSD-2-Clause */
/* malloc counted (for test_mg_kernels: the kernels of the time loop make no
 * heap allocation, a house rule). Linked into that test program only: its
 * malloc replaces glibc's for the whole process and forwards to it. */
#include <stddef.h>

extern void *__libc_malloc(size_t size);

static long calls = 0;

void *malloc(size_t size)
{
  calls++;
  return __libc_malloc(size);
}

/* malloc calls since the program started */
long nuno_test_malloc_calls(void) { return calls; }
