/* sonar-contracts.h: everything that passes between the elements, in one
 * place: the caps, the sticky set-up event, the metas and the bus messages.
 * docs/CONTRACTS.md describes the same contracts for users; keep both in
 * step. */
#ifndef SONAR_CONTRACTS_H
#define SONAR_CONTRACTS_H

#include <gst/gst.h>
#include "sonar-setup.h"
#include "sonar-simulator.h"

G_BEGIN_DECLS

/* Caps of the microphone recordings: one channel per microphone, the whole
 * recording window of a ping per buffer when the source is sonarsrc (other
 * sources may cut pings anywhere: the set-up's ping length says where a
 * ping ends). channel-mask 0 = channels are not loudspeaker positions. */
#define SONAR_RECORDING_CAPS \
  "audio/x-raw, format=(string)F32LE, layout=(string)interleaved, " \
  "rate=(int)[ 1, MAX ], channels=(int)[ 1, 256 ], channel-mask=(bitmask)0"

/* The set-up event ------------------------------------------------------*/

/* Sticky custom downstream event, sent before the first buffer and again
 * whenever the sensor changes. It survives tee and queue like caps do. */
#define SONAR_SETUP_EVENT_NAME "sonar-setup"

GstEvent *sonar_setup_event_new (const SonarSetup * setup);
gboolean sonar_event_is_setup (GstEvent * event);
/* NULL with @error when the event's structure is malformed. */
SonarSetup *sonar_setup_from_event (GstEvent * event, GError ** error);
/* Same from a bare structure (e.g. a saved one). */
SonarSetup *sonar_setup_from_structure (const GstStructure * s,
    GError ** error);

/* The ground-truth meta -------------------------------------------------*/

/* Attached by sonarsrc to every ping: the scene's truth for that ping.
 * Registered without tags, so that every transform keeps it. */
typedef struct
{
  GstMeta meta;
  guint64 ping_index;
  guint n_truths;
  SonarTruth *truths;
} SonarTruthMeta;

GType sonar_truth_meta_api_get_type (void);
const GstMetaInfo *sonar_truth_meta_get_info (void);
#define SONAR_TRUTH_META_API_TYPE (sonar_truth_meta_api_get_type ())

SonarTruthMeta *sonar_buffer_add_truth_meta (GstBuffer * buffer,
    guint64 ping_index, const SonarTruth * truths, guint n_truths);
#define sonar_buffer_get_truth_meta(b) \
  ((SonarTruthMeta *) gst_buffer_get_meta ((b), SONAR_TRUTH_META_API_TYPE))

/* Bus messages ----------------------------------------------------------*/

/* Element message posted by sonarsrc per ping (docs/CONTRACTS.md). */
#define SONAR_TRUTH_MESSAGE_NAME "sonar-truth"

GstStructure *sonar_truth_to_structure (guint64 ping_index,
    GstClockTime timestamp, const SonarTruth * truths, guint n_truths);

G_END_DECLS

#endif /* SONAR_CONTRACTS_H */
