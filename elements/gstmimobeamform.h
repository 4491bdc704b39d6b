/* gstmimobeamform.h: the MIMO virtual-array energyscape. */
#ifndef GST_MIMO_BEAMFORM_H
#define GST_MIMO_BEAMFORM_H

#include "gstsonarfilter.h"
#include "sonar-imager.h"

G_BEGIN_DECLS

#define GST_TYPE_MIMO_BEAMFORM (gst_mimo_beamform_get_type ())
G_DECLARE_FINAL_TYPE (GstMimoBeamform, gst_mimo_beamform, GST, MIMO_BEAMFORM,
    GstSonarFilter)

GST_ELEMENT_REGISTER_DECLARE (mimobeamform);

G_END_DECLS

#endif
