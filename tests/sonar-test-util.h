/* sonar-test-util.h: what the tests share: measurements in double
 * precision, independent of the code under test; the default sensor and
 * one ping through the core. Plain C: the core's tests link no GStreamer
 * (the elements' tests add sonar-test-gst.h). */
#ifndef SONAR_TEST_UTIL_H
#define SONAR_TEST_UTIL_H

#include <glib.h>

#include "sonar-doppler-bank.h"
#include "sonar-setup.h"
#include "sonar-simulator.h"
#include "sonar-spectrum.h"

G_BEGIN_DECLS

/* Linear cross-correlation r[lag] = sum_i x[i + lag] * y[i] for every lag
 * from -(ny - 1) to nx - 1; returns nx + ny - 1 values, r[0] being lag
 * -(ny - 1). Free with g_free. */
double *sonar_test_xcorr (const float *x, gsize nx, const float *y, gsize ny);

/* Lag (in samples, sub-sample precision: the correlation is upsampled by
 * 32 in the frequency domain and the peak refined by a parabola) at which
 * x best matches y delayed: x[i] ~ y[i - lag]. @peak (may be NULL)
 * receives the correlation value there. Searches lags in [min_lag, max_lag]. */
double sonar_test_delay (const float *x, gsize nx, const float *y, gsize ny,
    double min_lag, double max_lag, double *peak);

/* signal[t] += gain w(t - delay) for t < @length, w (@n samples, zero
 * outside) read between its samples by a Blackman-windowed sinc of 97
 * taps: independent of the core's interpolators. */
void sonar_test_add_delayed (float *signal, gsize length, const float *w,
    guint n, double delay, double gain);

/* @params describing @setup as it is (every field; the geometry and
 * waveforms @setup's own), for a test to change one thing of. */
void sonar_test_setup_params (SonarSetupParams * params,
    const SonarSetup * setup);

/* Max |v| and index. */
double sonar_test_max_abs (const double *v, gsize n, gsize * index);

/* Whether the suite runs under AddressSanitizer and UBSan (meson test
 * --setup asan sets SONAR_SANITIZED): their allocator is not glibc's, and
 * the code runs about five times slower. */
gboolean sonar_test_sanitized (void);

/* Path of a file in the source tree (SONAR_SOURCE_DIR). g_free it. */
char *sonar_test_source_path (const char *relative);

/* Writes @text to a new temporary file and returns its path (g_free it;
 * the file is removed at exit of the test program). */
char *sonar_test_write_temp (const char *basename, const char *text);

/* The default sensor (eRTIS array, 8 default noise emissions, 450 kHz,
 * c = 343 m/s) with @ping_length samples per ping. */
SonarSetup *sonar_test_default_setup (guint ping_length);

/* A set-up of @geometry (cleared here) with the default noise waveforms,
 * one per emitter. */
SonarSetup *sonar_test_setup_new (SonarGeometry * geometry,
    guint ping_length);

/* One ping through the core, without a pipeline: the default sensor
 * (17500 samples per ping), a band for a ping plus a template of up to
 * max_template samples (with a bank, its longest, and the bank's spectra
 * prepared on it), the band's analyser and a ping's buffers. */
typedef struct
{
  SonarSetup *setup;
  SonarDopplerBank *bank;       /* NULL unless made with one */
  SonarBand band;
  SonarSpectrum *analyzer;
  SonarComplex *mic_spectra;    /* microphones x n_bins */
  float *ping;                  /* microphones x ping_length, planar */
} SonarTestChain;

void sonar_test_chain_init (SonarTestChain * chain, guint max_template);
void sonar_test_chain_init_with_bank (SonarTestChain * chain, double v_min,
    double v_max, double v_step);
void sonar_test_chain_clear (SonarTestChain * chain);
/* The microphone spectra of chain->ping. */
void sonar_test_chain_spectra (SonarTestChain * chain);
/* Simulates @json (ping 0 at t = 0, noise of rms @noise) into
 * chain->ping, takes its spectra, returns the truth of reflector 0. */
SonarTruth sonar_test_chain_simulate (SonarTestChain * chain,
    const char *json, double noise);

G_END_DECLS

#endif
