/* fuzz-input.h: what the libFuzzer harnesses of the file loaders share. */
#ifndef FUZZ_INPUT_H
#define FUZZ_INPUT_H

#include <glib.h>
#include <stddef.h>
#include <stdint.h>

G_BEGIN_DECLS

/* Makes GLib criticals and warnings abort, so that libFuzzer reports them
 * as crashes: a loader must answer bad input with its GError only. */
void fuzz_input_init (void);

/* The path of a file holding exactly @data: the loaders read files, and
 * this one lives in memory (memfd), rewritten for every input. */
const char *fuzz_input_file (const uint8_t * data, size_t size);

G_END_DECLS

#endif
