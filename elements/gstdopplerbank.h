/* gstdopplerbank.h: the Doppler-tuned matched-filter bank. */
#ifndef GST_DOPPLER_BANK_H
#define GST_DOPPLER_BANK_H

#include "gstsonarfilter.h"

G_BEGIN_DECLS

#define GST_TYPE_DOPPLER_BANK (gst_doppler_bank_get_type ())
G_DECLARE_FINAL_TYPE (GstDopplerBank, gst_doppler_bank, GST, DOPPLER_BANK,
    GstSonarFilter)

GST_ELEMENT_REGISTER_DECLARE (dopplerbank);

G_END_DECLS

#endif
