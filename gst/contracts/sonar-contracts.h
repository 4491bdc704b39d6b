/* sonar-contracts.h: everything that passes between the elements, in one
 * place: the caps, the sticky set-up event, the metas and the bus messages.
 * docs/CONTRACTS.md describes the same contracts for users; keep both in
 * step. */
#ifndef SONAR_CONTRACTS_H
#define SONAR_CONTRACTS_H

#include <gst/gst.h>
#include <gst/audio/audio.h>
#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-image-grid.h"
#include "sonar-setup.h"
#include "sonar-simulator.h"
#include "sonar-track.h"

G_BEGIN_DECLS

/* Caps of the microphone recordings: one channel per microphone, the whole
 * recording window of a ping per buffer when the source is sonarsrc (other
 * sources may cut pings anywhere: the set-up's ping length says where a
 * ping ends). channel-mask 0 = channels are not loudspeaker positions. */
#define SONAR_RECORDING_CAPS \
  "audio/x-raw, format=(string)F32LE, layout=(string)interleaved, " \
  "rate=(int)[ 1, MAX ], channels=(int)[ 1, 256 ], channel-mask=(bitmask)0"

/* What dopplerbank takes: recordings made elsewhere too, in any raw
 * sample format (F32LE read as it is, the others through GStreamer's own
 * unpacking). A plain WAV carries no channel-mask (wavparse gives none for
 * WAVE_FORMAT_IEEE_FLOAT or PCM), so none is required; integer samples
 * are read as fractions of full scale. */
#define SONAR_RECORDING_FORMATS GST_AUDIO_FORMATS_ALL
#define SONAR_RECORDING_SINK_CAPS \
  "audio/x-raw, format=(string)" SONAR_RECORDING_FORMATS ", " \
  "layout=(string)interleaved, rate=(int)[ 1, MAX ], " \
  "channels=(int)[ 1, 256 ]"

/* The set-up event ------------------------------------------------------*/

/* Sticky custom downstream event, sent before the first buffer and again
 * whenever the sensor changes. It survives tee and queue like caps do. */
#define SONAR_SETUP_EVENT_NAME "sonar-setup"

GstEvent *sonar_setup_event_new (const SonarSetup * setup);
/* Whether @event is a set-up event: a custom downstream sticky event named
 * SONAR_SETUP_EVENT_NAME, or one that GStreamer's data protocol (gdppay,
 * gdpdepay) brought over with its type cut to 16 bits, which is how every
 * custom event arrives through it in GStreamer 1.22. */
gboolean sonar_event_is_setup (GstEvent * event);
/* @event (a set-up event, consumed) as a custom downstream sticky event:
 * the same, or, when it came through the data protocol, a new one with
 * its structure. */
GstEvent *sonar_setup_event_restore (GstEvent * event);
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

/* Microphone spectra (dopplerbank -> mimobeamform) ----------------------*/

/* One buffer per ping: channels x bins complex values (float32 real,
 * float32 imaginary), microphone-major, on the band bins first-bin ..
 * first-bin + bins - 1 of a real FFT of fft-size points at rate Hz. */
#define SONAR_SPECTRA_MEDIA_TYPE "application/x-sonar-spectra"
#define SONAR_SPECTRA_CAPS SONAR_SPECTRA_MEDIA_TYPE ", " \
  "channels=(int)[ 1, 256 ], rate=(int)[ 1, MAX ], fft-size=(int)[ 1, MAX ], " \
  "first-bin=(int)[ 0, MAX ], bins=(int)[ 1, MAX ]"

GstCaps *sonar_spectra_caps_new (guint channels, const SonarBand * band);
gboolean sonar_spectra_caps_parse (const GstCaps * caps, guint * channels,
    SonarBand * band);

/* The Doppler bank event --------------------------------------------------*/

/* Sticky custom downstream event from dopplerbank, after the set-up event:
 * the bank (a reference, not a copy) and the band its spectra are on. */
#define SONAR_BANK_EVENT_NAME "sonar-doppler-bank"

GType sonar_doppler_bank_get_type (void);
#define SONAR_TYPE_DOPPLER_BANK (sonar_doppler_bank_get_type ())

GstEvent *sonar_bank_event_new (SonarDopplerBank * bank,
    const SonarBand * band);
gboolean sonar_event_is_bank (GstEvent * event);
/* A new reference to the bank, or NULL when malformed. */
SonarDopplerBank *sonar_bank_from_event (GstEvent * event, SonarBand * band);

/* The spectra meta --------------------------------------------------------*/

/* mimobeamform attaches the ping's microphone spectra to its image, so that
 * velocityest can evaluate the bank where the reflectors are. Registered
 * without tags: every transform keeps it. */
typedef struct
{
  GstMeta meta;
  GstBuffer *spectra;           /* a SONAR_SPECTRA_MEDIA_TYPE buffer */
  guint channels;
  SonarBand band;
} SonarSpectraMeta;

GType sonar_spectra_meta_api_get_type (void);
#define SONAR_SPECTRA_META_API_TYPE (sonar_spectra_meta_api_get_type ())
SonarSpectraMeta *sonar_buffer_add_spectra_meta (GstBuffer * buffer,
    GstBuffer * spectra, guint channels, const SonarBand * band);
#define sonar_buffer_get_spectra_meta(b) \
  ((SonarSpectraMeta *) gst_buffer_get_meta ((b), SONAR_SPECTRA_META_API_TYPE))

/* Energyscapes (mimobeamform -> wardcluster) -----------------------------*/

/* A buffer holds one or more records (one per Doppler hypothesis in the
 * datacube mode), each a header then n_elevation x n_azimuth x n_range
 * float32 envelope values (pixel order of SonarImageGrid). Self-describing,
 * so that a file written by filesink can be read back (tools/energyscape.py).
 * Little-endian. */
#define SONAR_ENERGYSCAPE_MEDIA_TYPE "application/x-sonar-energyscape"
#define SONAR_ENERGYSCAPE_CAPS SONAR_ENERGYSCAPE_MEDIA_TYPE
#define SONAR_ENERGYSCAPE_MAGIC "SONARES1"

typedef struct
{
  char magic[8];                /* SONAR_ENERGYSCAPE_MAGIC */
  guint32 header_size;          /* 96: the data follows */
  guint32 n_azimuth, n_elevation, n_range;
  guint64 ping_index;
  double azimuth_first, azimuth_step;   /* degrees */
  double elevation_first, elevation_step;       /* degrees */
  double range_first, range_step;       /* m */
  double velocity;              /* m/s hypothesis; NaN: maximum over several */
  gint32 emitter;               /* -1: MIMO (all emitters), else one emitter */
  guint32 reserved;
} SonarEnergyscapeHeader;

G_STATIC_ASSERT (sizeof (SonarEnergyscapeHeader) == 96);

/* @hypotheses: the Doppler hypotheses each pixel of a record is the
 * maximum of (1: one envelope); it sets the noise statistics that
 * wardcluster's false-alarm threshold assumes. Parsing, an absent field
 * reads 1; @hypotheses may be NULL. */
GstCaps *sonar_energyscape_caps_new (const SonarImageGrid * grid,
    guint records, guint hypotheses);
gboolean sonar_energyscape_caps_parse (const GstCaps * caps,
    SonarImageGrid * grid, guint * records, guint * hypotheses);
void sonar_energyscape_header_init (SonarEnergyscapeHeader * header,
    const SonarImageGrid * grid, guint64 ping_index, double velocity,
    int emitter);
/* Grid of a header; FALSE when it is not a valid record header. */
gboolean sonar_energyscape_header_parse (const SonarEnergyscapeHeader *
    header, SonarImageGrid * grid);

/* Centroids (wardcluster -> velocityest) ---------------------------------*/

/* wardcluster passes the energyscape through and attaches the reflector
 * centroids it found, strongest first. Registered without tags. */
typedef struct
{
  GstMeta meta;
  guint64 ping_index;
  guint n_centroids;
  SonarCentroid *centroids;
} SonarCentroidsMeta;

GType sonar_centroids_meta_api_get_type (void);
#define SONAR_CENTROIDS_META_API_TYPE (sonar_centroids_meta_api_get_type ())
SonarCentroidsMeta *sonar_buffer_add_centroids_meta (GstBuffer * buffer,
    guint64 ping_index, const SonarCentroid * centroids, guint n);
#define sonar_buffer_get_centroids_meta(b) \
  ((SonarCentroidsMeta *) gst_buffer_get_meta ((b), \
      SONAR_CENTROIDS_META_API_TYPE))

/* Element message posted by wardcluster per ping. */
#define SONAR_CENTROIDS_MESSAGE_NAME "sonar-centroids"
GstStructure *sonar_centroids_to_structure (guint64 ping_index,
    GstClockTime timestamp, const SonarCentroid * centroids, guint n);

/* Detections (velocityest's results) -------------------------------------*/

typedef struct
{
  guint centroid;               /* index of the centroid it was found at */
  double range, azimuth, elevation;     /* m, degrees */
  SonarVec3 position;           /* m, sensor frame */
  /* s, the ping's clock: when the object was at that position and moving
   * at that radial velocity, the instant the emissions' energy centre
   * reaches it (sonar_velocity_centre_range ()); NaN without a ping
   * time. */
  double instant;
  double radial_velocity;       /* m/s, d(range)/dt: + moving away */
  gboolean approaching;         /* sonar_velocity_approaching (): at
                                 * -0.005 m/s or less */
  double confidence;            /* 0..1: share of emitters whose own curve agrees */
  gboolean out_of_range;        /* at the bank's edge: the speed may lie beyond */
  gboolean valid;               /* passed the false-positive tests */
  double peak_db;               /* Doppler-ACF product peak over its median, dB per emitter */
  double variance;              /* the paper's variance of the normalised product */
  /* How well it is known (sonar-uncertainty.h, docs/CONTRACTS.md §9):
   * the echo's envelope in the energyscape at its peak (dB re one unit of
   * the energyscape, before range compensation), its SNR over the image's
   * noise (dB), and 1-sigma uncertainties (m, degrees, degrees, m/s; NaN
   * when not measurable, elevation on a 2-D image). */
  double amplitude;
  double snr;
  double range_sigma, azimuth_sigma, elevation_sigma;
  double radial_velocity_sigma;
  /* The sensor's frame id (the set-up's, sonarsrc's frame-id property),
   * NUL-terminated; empty when none was given. */
  char frame_id[SONAR_FRAME_ID_MAX];
} SonarDetection;

typedef struct
{
  GstMeta meta;
  guint64 ping_index;
  guint n_detections;
  SonarDetection *detections;
} SonarDetectionsMeta;

GType sonar_detections_meta_api_get_type (void);
#define SONAR_DETECTIONS_META_API_TYPE (sonar_detections_meta_api_get_type ())
SonarDetectionsMeta *sonar_buffer_add_detections_meta (GstBuffer * buffer,
    guint64 ping_index, const SonarDetection * detections, guint n);
#define sonar_buffer_get_detections_meta(b) \
  ((SonarDetectionsMeta *) gst_buffer_get_meta ((b), \
      SONAR_DETECTIONS_META_API_TYPE))

/* Element message posted by velocityest per ping; @frame_id, the
 * sensor's (NULL: ""), names it when no detection does. */
#define SONAR_DETECTIONS_MESSAGE_NAME "sonar-detections"
GstStructure *sonar_detections_to_structure (guint64 ping_index,
    GstClockTime timestamp, const char *frame_id,
    const SonarDetection * detections, guint n);
/* One line of JSON (ending in a newline) with the ping's detections. */
char *sonar_detections_to_json (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarDetection * detections, guint n);

/* velocityest's output: UTF-8 text, one JSON line per ping. */
#define SONAR_DETECTIONS_CAPS "text/x-raw, format=(string)utf8"

/* Errors -----------------------------------------------------------------*/

/* Posts @error on the bus as an error of @element with its own domain and
 * code: the core's SONAR_ERROR codes (sonar-error.h) reach applications
 * as they are, which GST_ELEMENT_ERROR's fixed GStreamer domains would
 * hide. @debug (may be NULL) is the message's debug text. */
#define SONAR_ELEMENT_POST_ERROR(element, error, debug)                   \
  sonar_element_post_error (GST_ELEMENT (element), (error), (debug),     \
      __FILE__, GST_FUNCTION, __LINE__)
void sonar_element_post_error (GstElement * element, const GError * error,
    const char *debug, const char *file, const char *function, int line);

/* Tracks (sonartrack's results) ------------------------------------------*/

/* The ping's ego-motion and tracks, on sonartrack's output buffer.
 * Registered without tags. */
typedef struct
{
  GstMeta meta;
  guint64 ping_index;
  SonarEgoMotion ego;           /* the ping's own estimate (sonar-egomotion.h) */
  guint n_tracks;
  SonarTrack *tracks;           /* by id (sonar-track.h) */
  char frame_id[SONAR_FRAME_ID_MAX];    /* the detections' ("" for none) */
} SonarTracksMeta;

GType sonar_tracks_meta_api_get_type (void);
#define SONAR_TRACKS_META_API_TYPE (sonar_tracks_meta_api_get_type ())
SonarTracksMeta *sonar_buffer_add_tracks_meta (GstBuffer * buffer,
    guint64 ping_index, const SonarEgoMotion * ego,
    const SonarTrack * tracks, guint n);
#define sonar_buffer_get_tracks_meta(b) \
  ((SonarTracksMeta *) gst_buffer_get_meta ((b), SONAR_TRACKS_META_API_TYPE))

/* Element message posted by sonartrack per ping. */
#define SONAR_TRACKS_MESSAGE_NAME "sonar-tracks"
GstStructure *sonar_tracks_to_structure (guint64 ping_index,
    GstClockTime timestamp, const char *frame_id, const SonarEgoMotion * ego,
    const SonarTrack * tracks, guint n);
/* One line of JSON (ending in a newline) with the ping's ego-motion and
 * tracks, in frame @frame_id (the detections'; NULL or "" for none). */
char *sonar_tracks_to_json (guint64 ping_index, GstClockTime timestamp,
    const char *frame_id, const SonarEgoMotion * ego,
    const SonarTrack * tracks, guint n);

/* Custom upstream event an application sends to sonartrack with its own
 * estimate of the sensor's velocity (odometry): fields vx, vy, vz (m/s,
 * sensor frame) and sigma (m/s per axis; 0 removes the prior). */
#define SONAR_EGO_PRIOR_EVENT_NAME "sonar-ego-prior"
GstEvent *sonar_ego_prior_event_new (SonarVec3 velocity, double sigma);
/* FALSE when @event is not a well-formed ego prior event. */
gboolean sonar_ego_prior_event_parse (GstEvent * event, SonarVec3 * velocity,
    double *sigma);

G_END_DECLS

#endif /* SONAR_CONTRACTS_H */
