/* sonar-error.c: see sonar-error.h. */
#include "sonar-error.h"

G_DEFINE_QUARK (sonar-error-quark, sonar_error)
