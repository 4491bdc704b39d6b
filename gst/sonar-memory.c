/* sonar-memory.c: see sonar-memory.h. */
#include "sonar-memory.h"
#include "sonar-error.h"

#include <gio/gio.h>
#include <stdarg.h>

GParamSpec *
sonar_memory_param_spec (GParamFlags flags)
{
  return g_param_spec_uint64 ("max-memory", "Maximum memory", "Most "
      "memory, in bytes, that the sizes set by the other properties may "
      "make this element allocate; beyond it, starting is an error that "
      "names them (rather than an abort when an allocation fails)", 0,
      G_MAXUINT64, SONAR_DEFAULT_MAX_MEMORY, flags);
}

guint64
sonar_memory_array (guint64 count, guint64 size)
{
  guint64 bytes;

  return g_uint64_checked_mul (&bytes, count, size) ? bytes : G_MAXUINT64;
}

guint64
sonar_memory_add (guint64 a, guint64 b)
{
  guint64 bytes;

  return g_uint64_checked_add (&bytes, a, b) ? bytes : G_MAXUINT64;
}

/* "5.9 GiB", the same in every locale (g_format_size's spaces and
 * decimal separator follow it). */
static char *
format_size (guint64 bytes)
{
  static const char *const units[] = { "bytes", "KiB", "MiB", "GiB", "TiB",
    "PiB", "EiB"
  };
  char number[G_ASCII_DTOSTR_BUF_SIZE];
  double value = (double) bytes;
  guint unit = 0;

  while (value >= 1024.0 && unit + 1 < G_N_ELEMENTS (units)) {
    value /= 1024.0;
    unit++;
  }
  if (unit == 0)
    return g_strdup_printf ("%" G_GUINT64_FORMAT " bytes", bytes);
  return g_strdup_printf ("%s %s", g_ascii_formatd (number, sizeof (number),
          "%.1f", value), units[unit]);
}

/* "5.9 GiB (6357437856 bytes)" */
static char *
format_bytes (guint64 bytes)
{
  g_autofree char *size = NULL;

  if (bytes == G_MAXUINT64)
    return g_strdup ("more than 16 EiB");
  size = format_size (bytes);
  return g_strdup_printf ("%s (%" G_GUINT64_FORMAT " bytes)", size, bytes);
}

static gboolean
check_memory (guint64 bytes, guint64 max_memory, GError ** error,
    const char *format, va_list args)
{
  g_autofree char *what = NULL;
  g_autofree char *needed = NULL;
  g_autofree char *allowed = NULL;

  if (bytes <= max_memory)
    return TRUE;
  what = g_strdup_vprintf (format, args);
  needed = format_bytes (bytes);
  allowed = format_size (max_memory);
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_MEMORY, "%s needs %s, more "
      "than max-memory (%s)", what, needed, allowed);
  return FALSE;
}

gboolean
sonar_memory_check (guint64 bytes, guint64 max_memory, GError ** error,
    const char *format, ...)
{
  va_list args;
  gboolean ok;

  va_start (args, format);
  ok = check_memory (bytes, max_memory, error, format, args);
  va_end (args);
  return ok;
}

gboolean
sonar_memory_check_buffers (guint64 held_bytes, guint64 buffer_size,
    guint n_buffers, guint64 max_memory, GError ** error,
    const char *format, ...)
{
  va_list args;
  gboolean ok;

  va_start (args, format);
  if (buffer_size > G_MAXUINT) {
    g_autofree char *what = g_strdup_vprintf (format, args);
    g_autofree char *size = format_bytes (buffer_size);
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_MEMORY, "%s: an output "
        "buffer of %s is more than a GStreamer buffer pool holds (%u bytes)",
        what, size, G_MAXUINT);
    ok = FALSE;
  } else {
    ok = check_memory (sonar_memory_add (held_bytes,
            sonar_memory_array (buffer_size, n_buffers)), max_memory, error,
        format, args);
  }
  va_end (args);
  return ok;
}
