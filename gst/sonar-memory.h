/* sonar-memory.h: the memory a configuration will need, checked before it
 * is allocated. A setting too large for the machine must be an error that
 * names it, not an abort in g_malloc (GLib aborts when an allocation
 * fails), nor a size wrapped to 32 bits on its way to a buffer pool. */
#ifndef SONAR_MEMORY_H
#define SONAR_MEMORY_H

#include <glib-object.h>

G_BEGIN_DECLS

/* Default of the elements' max-memory property, bytes (4 GiB). */
#define SONAR_DEFAULT_MAX_MEMORY (G_GUINT64_CONSTANT (4) << 30)

/* The max-memory property (bytes, default SONAR_DEFAULT_MAX_MEMORY) of the
 * elements that allocate by sizes their settings give: dopplerbank (the
 * bank and its spectra), mimobeamform (the images), velocityest (the
 * residual search's spectra and image), sonarsrc (the recording window);
 * docs/CONTRACTS.md, section 11. */
GParamSpec *sonar_memory_param_spec (GParamFlags flags);

/* @count elements of @size bytes, and sums of such, saturating at
 * G_MAXUINT64: an estimate never wraps to something small. */
guint64 sonar_memory_array (guint64 count, guint64 size);
guint64 sonar_memory_add (guint64 a, guint64 b);

/* FALSE with @error set when @bytes is more than @max_memory: "<what>
 * needs 5.9 GiB (6358913952 bytes), more than max-memory (4.0 GiB)",
 * <what> being the printf-style @format, which names the settings. */
gboolean sonar_memory_check (guint64 bytes, guint64 max_memory,
    GError ** error, const char *format, ...) G_GNUC_PRINTF (4, 5);

/* The same for @held_bytes plus @n_buffers output buffers of
 * @buffer_size bytes from a GstBufferPool, which also refuses buffers of
 * more than G_MAXUINT bytes (the pool's size parameter is a guint). */
gboolean sonar_memory_check_buffers (guint64 held_bytes,
    guint64 buffer_size, guint n_buffers, guint64 max_memory,
    GError ** error, const char *format, ...) G_GNUC_PRINTF (6, 7);

G_END_DECLS

#endif
