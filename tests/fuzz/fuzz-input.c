/* fuzz-input.c: see fuzz-input.h. */
#include "fuzz-input.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

static int input_fd = -1;
static char input_path[64];

void
fuzz_input_init (void)
{
  g_log_set_always_fatal (G_LOG_FATAL_MASK | G_LOG_LEVEL_CRITICAL
      | G_LOG_LEVEL_WARNING);
  input_fd = memfd_create ("fuzz-input.json", MFD_CLOEXEC);
  if (input_fd < 0) {
    perror ("memfd_create");
    abort ();
  }
  g_snprintf (input_path, sizeof (input_path), "/proc/self/fd/%d", input_fd);
}

const char *
fuzz_input_file (const uint8_t * data, size_t size)
{
  if (ftruncate (input_fd, 0) != 0
      || (size > 0 && pwrite (input_fd, data, size, 0) != (ssize_t) size)) {
    perror ("fuzz input");
    abort ();
  }
  return input_path;
}
