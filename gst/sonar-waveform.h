/* sonar-waveform.h: the emission waveforms of the MIMO sonar.
 *
 * One waveform per emitter, all emitted at the same instant. The default is
 * the paper's: band-passed (20-80 kHz) pseudo-random white Gaussian noise,
 * 4000 samples at 450 kHz, one seeded sequence per emitter. Independent
 * noise only reaches about 17 dB between auto- and cross-correlation peaks,
 * so the set is then nudged jointly (a few deterministic gradient steps)
 * until every cross-correlation peak is more than 20 dB down. The
 * hyperbolic FM chirp and the multisine are the alternatives the paper
 * compares (its Fig. 1 and 2).
 */
#ifndef SONAR_WAVEFORM_H
#define SONAR_WAVEFORM_H

#include <glib.h>

G_BEGIN_DECLS

/* The kinds. Adding one is a value here, an entry of the kinds table
 * (sonar-waveform.c) and its generator: sonarsrc's property, the tools
 * and the tests take their names and descriptions from the table. */
typedef enum
{
  SONAR_WAVEFORM_NOISE,             /* band-passed pseudo-random Gaussian noise (PR-AWGN) */
  SONAR_WAVEFORM_HYPERBOLIC_CHIRP,  /* hyperbolic FM sweep across the band */
  SONAR_WAVEFORM_MULTISINE,         /* sum of in-band sines, random phases */
} SonarWaveformKind;

typedef struct
{
  SonarWaveformKind kind;
  const char *nick;             /* "noise": property values, files, tools */
  const char *description;      /* one line, for gst-inspect and --help */
} SonarWaveformKindInfo;

/* Every kind, in the enum's order: *n_kinds of them. */
const SonarWaveformKindInfo *sonar_waveform_kinds (guint * n_kinds);

typedef struct
{
  SonarWaveformKind kind;
  guint n_emitters;             /* rows to generate, >= 1 */
  guint length;                 /* samples per waveform, >= 16 */
  double sample_rate;           /* Hz */
  double band_low;              /* Hz, 0 < band_low < band_high <= sample_rate / 2 */
  double band_high;             /* Hz */
  guint64 seed;                 /* same seed, same waveforms, on every machine */
} SonarWaveformParams;

/* The paper's set-up: noise, 8 emitters, 4000 samples, 450 kHz, 20-80 kHz. */
void sonar_waveform_params_init_default (SonarWaveformParams * params);

/* Fills out[n_emitters * length] (row n is emitter n). Each row has unit
 * peak amplitude and is tapered at both ends. Returns FALSE and sets
 * @error (SONAR_ERROR_SETTINGS) when a parameter is out of range. */
gboolean sonar_waveform_generate (const SonarWaveformParams * params,
    float *out, GError ** error);

/* The kind's nick, or the kind of a nick; NULL / FALSE when unknown. */
const char *sonar_waveform_kind_to_string (SonarWaveformKind kind);
gboolean sonar_waveform_kind_from_string (const char *name,
    SonarWaveformKind * kind);
/* The nicks joined by @separator ("noise, hyperbolic-chirp, multisine"),
 * for messages. g_free it. */
char *sonar_waveform_kind_nicks (const char *separator);

G_END_DECLS

#endif /* SONAR_WAVEFORM_H */
