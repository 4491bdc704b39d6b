/* plugin.c: the "sonar" plugin, registering every element of the set. */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif
#include <gst/gst.h>

#include "gstdopplerbank.h"
#include "gstmimobeamform.h"
#include "gstsonarsrc.h"
#include "gstsonartrack.h"
#include "gstsonarviz.h"
#include "gstvelocityest.h"
#include "gstwardcluster.h"

static gboolean
plugin_init (GstPlugin * plugin)
{
  gboolean ok = FALSE;

  ok |= GST_ELEMENT_REGISTER (sonarsrc, plugin);
  ok |= GST_ELEMENT_REGISTER (dopplerbank, plugin);
  ok |= GST_ELEMENT_REGISTER (mimobeamform, plugin);
  ok |= GST_ELEMENT_REGISTER (wardcluster, plugin);
  ok |= GST_ELEMENT_REGISTER (velocityest, plugin);
  ok |= GST_ELEMENT_REGISTER (sonarviz, plugin);
  ok |= GST_ELEMENT_REGISTER (sonartrack, plugin);
  return ok;
}

GST_PLUGIN_DEFINE (GST_VERSION_MAJOR, GST_VERSION_MINOR, sonar,
    "MIMO in-air sonar: simulation, Doppler matched-filter bank, imaging, "
    "clustering, radial velocity estimation, ego-motion, tracks and display", plugin_init, VERSION,
    "LGPL", PACKAGE, PACKAGE_ORIGIN)
