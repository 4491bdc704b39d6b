/* sonar-error.h: the core's error domain.
 *
 * Every GError the core sets is SONAR_ERROR with one of these codes, so
 * that a caller (an element, an application) can tell what to do about it
 * without parsing its message; the message names the problem and the
 * value. The elements post them as they are (docs/CONTRACTS.md, Errors).
 */
#ifndef SONAR_ERROR_H
#define SONAR_ERROR_H

#include <glib.h>

G_BEGIN_DECLS

#define SONAR_ERROR (sonar_error_quark ())
GQuark sonar_error_quark (void);

typedef enum
{
  /* A setting out of its range, or settings that contradict each other:
   * change the setting. */
  SONAR_ERROR_SETTINGS,
  /* A file, event or recording that is not what its format says (docs/
   * FORMATS.md, docs/CONTRACTS.md): fix or replace it. */
  SONAR_ERROR_FORMAT,
  /* A file that cannot be opened, read or written (the system's reason in
   * the message). */
  SONAR_ERROR_FILE,
  /* The set-up would need more memory than max-memory allows, or a buffer
   * larger than GStreamer's pools hold. */
  SONAR_ERROR_MEMORY,
  /* The system refused a resource (a worker thread). */
  SONAR_ERROR_RESOURCE,
} SonarErrorCode;

G_END_DECLS

#endif
