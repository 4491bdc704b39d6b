/* fuzz-input.c: see fuzz-input.h. */
#include "fuzz-input.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <unistd.h>

static int input_fd = -1;
static char input_path[64];

/* abort(), not GLib's fatal-log breakpoint (SIGTRAP): libFuzzer catches
 * SIGABRT and saves the input that caused it. */
static void
abort_on_log (const char *domain, GLogLevelFlags level, const char *message,
    gpointer data)
{
  g_log_default_handler (domain, level, message, data);
  if (level & (G_LOG_FLAG_FATAL | G_LOG_LEVEL_ERROR | G_LOG_LEVEL_CRITICAL
          | G_LOG_LEVEL_WARNING))
    abort ();
}

void
fuzz_input_init (void)
{
  g_log_set_default_handler (abort_on_log, NULL);
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
