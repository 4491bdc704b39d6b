/* sonar-spectrum.h: the frequency grid the matched filters and the
 * beamformer work on, and the front end that takes recordings onto it.
 *
 * A matched filter (paper eq. 2 and 10) is a product of spectra; only the
 * bins of the sonar's band carry signal, so every spectrum in the chain is
 * kept on those bins alone: a SonarBand. Linear (not circular) correlation
 * over a whole ping needs an FFT of at least ping + template samples.
 */
#ifndef SONAR_SPECTRUM_H
#define SONAR_SPECTRUM_H

#include <complex.h>
#include <glib.h>

G_BEGIN_DECLS

typedef float complex SonarComplex;

/* glibc defines C11's CMPLXF for GCC only; clang has the same builtin. */
#ifndef CMPLXF
#define CMPLXF(x, y) __builtin_complex ((float) (x), (float) (y))
#endif

typedef struct
{
  double sample_rate;           /* Hz */
  guint fft_size;               /* N: real FFT length, samples */
  guint first_bin;              /* k0: bin of the first kept frequency */
  guint n_bins;                 /* K: kept bins k0 .. k0 + K - 1 */
} SonarBand;

/* Spectra with real and imaginary parts in two arrays (the steering
 * kernels' layout, sonar-kernels.h); k-th value re[k] + i im[k]. */
typedef struct
{
  const float *re, *im;
} SonarSplitSpectra;

/* Smallest 2^a 3^b 5^c >= n: a size FFTW transforms fast. */
guint sonar_fft_good_size (guint n);

/* The smallest 2^a or 3 x 2^a at least @n: the sizes FFTW_ESTIMATE plans
 * best (a transform of 3072 points runs in half the time of one of 2916,
 * 2^2 x 3^6), for transforms run many times per ping. */
guint sonar_fft_fast_size (guint n);

/* A grid of at least @min_fft_size points whose kept bins cover
 * [low, high] Hz (plus one bin each side). */
void sonar_band_init (SonarBand * band, double sample_rate,
    guint min_fft_size, double low, double high);

static inline gboolean
sonar_band_equal (const SonarBand * a, const SonarBand * b)
{
  return a->sample_rate == b->sample_rate && a->fft_size == b->fft_size
      && a->first_bin == b->first_bin && a->n_bins == b->n_bins;
}

static inline double
sonar_band_frequency (const SonarBand * band, guint bin)
{
  return (band->first_bin + bin) * band->sample_rate / band->fft_size;
}

/* Spectra of real signals on a band, with plans made once at creation. */
typedef struct _SonarSpectrum SonarSpectrum;

SonarSpectrum *sonar_spectrum_new (const SonarBand * band);
void sonar_spectrum_free (SonarSpectrum * spectrum);

/* Spectrum of @length samples read at @stride (zero-padded to the FFT
 * size, and cut to it when longer) into @out[n_bins]. Non-finite samples
 * are read as 0 and counted into *n_bad (if not NULL). */
void sonar_spectrum_process (SonarSpectrum * spectrum, const float *signal,
    gsize length, gsize stride, SonarComplex * out, guint * n_bad);

/* The spectra of every channel of a ping's interleaved recordings, the
 * channels shared by workers (each with its own SonarSpectrum: FFTW's
 * plans execute concurrently on separate arrays). */
typedef struct _SonarChannelSpectra SonarChannelSpectra;

/* For @n_channels channels on @band, @threads workers (0: one per
 * processor). NULL with @error when the workers cannot be made. */
SonarChannelSpectra *sonar_channel_spectra_new (const SonarBand * band,
    guint n_channels, guint threads, GError ** error);
void sonar_channel_spectra_free (SonarChannelSpectra * spectra);

/* The spectra of @length frames of the channels interleaved in
 * @samples into @out: channel j's n_bins from out + j n_bins, each as
 * sonar_spectrum_process () makes it of the channel with its glitches
 * removed (sonar_remove_glitches (); bit for bit, whatever the workers),
 * a loud channel's zeros (below). Returns how many samples were not
 * finite (read as 0). */
guint sonar_channel_spectra_process (SonarChannelSpectra * spectra,
    const float *samples, gsize length, SonarComplex * out);

/* Glitches: impulsive samples (a bit error, a lost word, a driver's
 * garbage), no echo. An echo is band-limited: it rises and falls over
 * several samples. A glitch's energy spreads over the whole band and,
 * after the matched filters, over every direction of the image at its
 * range: one float sample of 10^5 among echoes of about 1 hid 3 of Fig.
 * 10's 6 objects. A glitch is a run of at most SONAR_GLITCH_MAX_RUN
 * samples whose peak is
 * - louder than SONAR_GLITCH_OVER_QUIET times the channel's quiet peak
 *   (the lower quartile of its SONAR_GLITCH_BLOCKS blocks' largest
 *   |sample|, about 3.3 times noise's RMS: the direct path and the
 *   nearest echoes fill fewer blocks), and
 * - more than SONAR_GLITCH_OVER_NEIGHBOURS times every sample within
 *   SONAR_GLITCH_FLANK of the run (the run: the samples around the peak
 *   over 1 / SONAR_GLITCH_OVER_NEIGHBOURS of it).
 * No band-limited signal does that, however loud: the direct path, a
 * clipped echo and the band's lowest tone all keep loud samples beside
 * their peaks (tests/test-spectrum.c). */
#define SONAR_GLITCH_OVER_QUIET 10.0f
#define SONAR_GLITCH_BLOCKS 16
#define SONAR_GLITCH_OVER_NEIGHBOURS 10.0f
/* 16: a burst of 9 samples on one microphone made false objects when
 * runs of 8 were the most; an echo lasts as long as its emission (4000
 * samples here), and a band-limited signal's loud run is followed, within
 * half a period of the band's lowest frequency (11 samples for 20 kHz at
 * 450 kHz), by more. */
#define SONAR_GLITCH_MAX_RUN 16
#define SONAR_GLITCH_FLANK 16

/* Zeroes the glitches of the @n samples of @x (one channel's ping, finite)
 * and returns how many samples it zeroed; *@largest (may be NULL) becomes
 * the largest |sample| zeroed if that is more, *@quiet (may be NULL) the
 * channel's quiet peak. One read of @x when no sample is that loud. */
guint sonar_remove_glitches (float *x, gsize n, float *largest,
    float *quiet);

/* A loud channel: its quiet peak (sonar_remove_glitches ()) over
 * SONAR_LOUD_CHANNEL_RATIO times the median channel's (20 dB), of
 * SONAR_LOUD_CHANNEL_MIN_CHANNELS or more. Where the array records no
 * echo its microphones hear the same noise, within the few dB their
 * gains differ by; a channel 20 dB over the others there holds a hum or
 * a bad channel's noise, which the matched filters spread over the
 * image: one microphone with a 40 kHz hum 29 dB over its noise lost 1 of
 * 3 foreign objects, 39 dB 2 of 3. Its spectrum is read as 0: the array
 * loses one microphone of its aperture, the image its noise. */
#define SONAR_LOUD_CHANNEL_RATIO 10.0f
#define SONAR_LOUD_CHANNEL_MIN_CHANNELS 4

/* After sonar_channel_spectra_process (): the loud channels it read as 0
 * (their spectra zeros), the first of them in *@first (may be NULL) and
 * in *@loudest_db (may be NULL) the loudest one's quiet peak over the
 * median channel's, dB (-inf when none). */
guint sonar_channel_spectra_loud (const SonarChannelSpectra * spectra,
    guint * first, double *loudest_db);

/* After sonar_channel_spectra_process (): the samples it zeroed as
 * glitches, and (@largest, may be NULL) the largest of them in magnitude
 * (0 when none). */
guint sonar_channel_spectra_glitches (const SonarChannelSpectra * spectra,
    float *largest);

/* The emissions heard straight from the emitters (sonar-direct-path.h):
 * what the front end does with them. */
typedef struct _SonarDirectPath SonarDirectPath;

typedef enum
{
  SONAR_DIRECT_PATH_OFF,
  SONAR_DIRECT_PATH_AUTO,
  SONAR_DIRECT_PATH_ALWAYS,
} SonarDirectPathMode;

/* Before each channel's spectrum, fits the emissions' direct path to it
 * and subtracts it as @mode says (sonar-direct-path.h; channel j is
 * microphone j; OFF or a NULL @path: none, the default). @path must
 * outlive the spectra or the next call. */
void sonar_channel_spectra_set_direct_path (SonarChannelSpectra * spectra,
    const SonarDirectPath * path, SonarDirectPathMode mode);

/* After sonar_channel_spectra_process (): the channels the direct path
 * was subtracted from, and (@largest_db, may be NULL) the largest power
 * a channel's fit explained over noise's, in dB (-inf without a direct
 * path set). */
guint sonar_channel_spectra_direct_path_removed (const SonarChannelSpectra *
    spectra, double *largest_db);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarSpectrum, sonar_spectrum_free)
G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarChannelSpectra,
    sonar_channel_spectra_free)

G_END_DECLS

#endif
