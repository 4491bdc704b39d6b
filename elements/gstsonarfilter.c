/* gstsonarfilter.c: see gstsonarfilter.h. */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstsonarfilter.h"

GST_DEBUG_CATEGORY_STATIC (sonar_filter_debug);
#define GST_CAT_DEFAULT sonar_filter_debug

typedef struct
{
  GstPad *sinkpad, *srcpad;

  GstCaps *in_caps;
  GstEvent *segment;            /* held until the output caps are out */
  SonarSetup *setup;
  GstEvent *setup_event;
  SonarDopplerBank *bank;
  SonarBand band;
  GstEvent *bank_event;
  gboolean configured;
  GstBufferPool *pool;          /* output buffers, when the subclass asked */
} GstSonarFilterPrivate;

G_DEFINE_ABSTRACT_TYPE_WITH_CODE (GstSonarFilter, gst_sonar_filter,
    GST_TYPE_ELEMENT, G_ADD_PRIVATE (GstSonarFilter);
    GST_DEBUG_CATEGORY_INIT (sonar_filter_debug, "sonarfilter", 0,
        "sonar processing element base"));

#define PRIV(f) ((GstSonarFilterPrivate *) \
    gst_sonar_filter_get_instance_private (GST_SONAR_FILTER (f)))

SonarSetup *
gst_sonar_filter_get_setup (GstSonarFilter * filter)
{
  return PRIV (filter)->setup;
}

SonarDopplerBank *
gst_sonar_filter_get_bank (GstSonarFilter * filter)
{
  return PRIV (filter)->bank;
}

const SonarBand *
gst_sonar_filter_get_band (GstSonarFilter * filter)
{
  return PRIV (filter)->bank ? &PRIV (filter)->band : NULL;
}

GstPad *
gst_sonar_filter_get_srcpad (GstSonarFilter * filter)
{
  return PRIV (filter)->srcpad;
}

void
gst_sonar_filter_set_bank (GstSonarFilter * filter, SonarDopplerBank * bank,
    const SonarBand * band)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
  gst_clear_event (&priv->bank_event);
  priv->bank = sonar_doppler_bank_ref (bank);
  priv->band = *band;
  priv->bank_event = sonar_bank_event_new (bank, band);
}

gboolean
gst_sonar_filter_use_pool (GstSonarFilter * filter, GstCaps * caps,
    gsize size)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstBufferPool *pool;
  GstStructure *config;

  /* The pool's size is a guint: a larger one would wrap. */
  if (size > G_MAXUINT)
    return FALSE;
  pool = gst_buffer_pool_new ();
  config = gst_buffer_pool_get_config (pool);
  /* No upper bound: a tee or queue downstream may hold several pings. */
  gst_buffer_pool_config_set_params (config, caps, size,
      GST_SONAR_FILTER_POOL_MIN_BUFFERS, 0);
  if (!gst_buffer_pool_set_config (pool, config)
      || !gst_buffer_pool_set_active (pool, TRUE)) {
    gst_object_unref (pool);
    return FALSE;
  }
  priv->pool = pool;
  return TRUE;
}

GstBuffer *
gst_sonar_filter_new_buffer (GstSonarFilter * filter, gsize size)
{
  GstSonarFilterPrivate *priv = PRIV (filter);
  GstBuffer *buffer = NULL;

  if (!priv->pool)
    return gst_buffer_new_allocate (NULL, size, NULL);
  if (gst_buffer_pool_acquire_buffer (priv->pool, &buffer, NULL) !=
      GST_FLOW_OK)
    return NULL;
  return buffer;
}

GstFlowReturn
gst_sonar_filter_push (GstSonarFilter * filter, GstBuffer * buffer)
{
  return gst_pad_push (PRIV (filter)->srcpad, buffer);
}

static void
unconfigure (GstSonarFilter * filter)
{
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  if (priv->configured && klass->unconfigure)
    klass->unconfigure (filter);
  priv->configured = FALSE;
  if (priv->pool) {
    gst_buffer_pool_set_active (priv->pool, FALSE);
    gst_clear_object (&priv->pool);
  }
}

static void
clear_state (GstSonarFilter * filter)
{
  GstSonarFilterPrivate *priv = PRIV (filter);

  unconfigure (filter);
  gst_clear_caps (&priv->in_caps);
  gst_clear_event (&priv->segment);
  gst_clear_event (&priv->setup_event);
  gst_clear_event (&priv->bank_event);
  g_clear_pointer (&priv->setup, sonar_setup_unref);
  g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
}

static gboolean
configure (GstSonarFilter * filter)
{
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);
  GError *error = NULL;
  GstCaps *out_caps;

  if (klass->make_setup) {
    SonarSetup *own = klass->make_setup (filter, priv->in_caps, &error);
    if (error) {
      GST_ELEMENT_ERROR (filter, RESOURCE, SETTINGS, ("%s", error->message),
          (NULL));
      g_error_free (error);
      return FALSE;
    }
    if (own) {
      g_clear_pointer (&priv->setup, sonar_setup_unref);
      priv->setup = own;
      gst_clear_event (&priv->setup_event);
      priv->setup_event = sonar_setup_event_new (own);
    }
  }
  if (!priv->setup) {
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("No sonar set-up arrived before the data: %s needs the array "
            "geometry and emission waveforms (the sonar-setup event that "
            "sonarsrc sends; for a recording, set dopplerbank's "
            "waveforms-file and ping-length)", GST_OBJECT_NAME (filter)),
        (NULL));
    return FALSE;
  }
  if (klass->needs_bank && !priv->bank) {
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("No Doppler bank arrived before the data: %s must follow "
            "dopplerbank", GST_OBJECT_NAME (filter)), (NULL));
    return FALSE;
  }
  unconfigure (filter);
  out_caps = klass->configure (filter, priv->in_caps, &error);
  if (!out_caps) {
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION, ("%s", error->message),
        (NULL));
    g_error_free (error);
    return FALSE;
  }
  priv->configured = TRUE;
  if (!gst_pad_push_event (priv->srcpad, gst_event_new_caps (out_caps))) {
    g_autofree char *text = gst_caps_to_string (out_caps);
    GST_ELEMENT_ERROR (filter, CORE, NEGOTIATION,
        ("Downstream does not accept the output of %s: %s",
            GST_OBJECT_NAME (filter), text), (NULL));
    gst_caps_unref (out_caps);
    return FALSE;
  }
  gst_caps_unref (out_caps);
  if (priv->segment)
    gst_pad_push_event (priv->srcpad, gst_event_ref (priv->segment));
  gst_pad_push_event (priv->srcpad, gst_event_ref (priv->setup_event));
  if (priv->bank_event)
    gst_pad_push_event (priv->srcpad, gst_event_ref (priv->bank_event));
  return TRUE;
}

static GstFlowReturn
gst_sonar_filter_chain (GstPad * pad, GstObject * parent, GstBuffer * buffer)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);

  if (!PRIV (filter)->configured && !configure (filter)) {
    gst_buffer_unref (buffer);
    return GST_FLOW_NOT_NEGOTIATED;
  }
  return GST_SONAR_FILTER_GET_CLASS (filter)->process (filter, buffer);
}

static gboolean
gst_sonar_filter_sink_event (GstPad * pad, GstObject * parent,
    GstEvent * event)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (parent);
  GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  /* A set-up that crossed a network (gdppay) comes with its type cut. */
  if (sonar_event_is_setup (event))
    event = sonar_setup_event_restore (event);
  switch (GST_EVENT_TYPE (event)) {
    case GST_EVENT_CAPS:{
      GstCaps *caps;
      gst_event_parse_caps (event, &caps);
      gst_caps_replace (&priv->in_caps, caps);
      unconfigure (filter);
      gst_event_unref (event);
      return TRUE;
    }
    case GST_EVENT_SEGMENT:
      gst_event_replace (&priv->segment, event);
      if (priv->configured)
        return gst_pad_push_event (priv->srcpad, event);
      gst_event_unref (event);
      return TRUE;
    case GST_EVENT_CUSTOM_DOWNSTREAM_STICKY:
      if (sonar_event_is_setup (event)) {
        GError *error = NULL;
        SonarSetup *setup = sonar_setup_from_event (event, &error);
        if (!setup) {
          GST_ELEMENT_ERROR (filter, STREAM, FORMAT, ("%s", error->message),
              (NULL));
          g_error_free (error);
          gst_event_unref (event);
          return FALSE;
        }
        if (priv->setup && sonar_setup_equal (priv->setup, setup)) {
          sonar_setup_unref (setup);
          gst_event_unref (event);
          return TRUE;
        }
        g_clear_pointer (&priv->setup, sonar_setup_unref);
        priv->setup = setup;
        gst_event_replace (&priv->setup_event, event);
        gst_event_unref (event);
        unconfigure (filter);
        return TRUE;
      }
      if (sonar_event_is_bank (event) && klass->needs_bank) {
        SonarBand band;
        SonarDopplerBank *bank = sonar_bank_from_event (event, &band);
        if (!bank) {
          GST_ELEMENT_ERROR (filter, STREAM, FORMAT,
              ("Malformed %s event", SONAR_BANK_EVENT_NAME), (NULL));
          gst_event_unref (event);
          return FALSE;
        }
        g_clear_pointer (&priv->bank, sonar_doppler_bank_unref);
        priv->bank = bank;
        priv->band = band;
        gst_event_replace (&priv->bank_event, event);
        gst_event_unref (event);
        unconfigure (filter);
        return TRUE;
      }
      if (sonar_event_is_bank (event)) {
        /* dopplerbank makes its own bank: an upstream one is stale. */
        gst_event_unref (event);
        return TRUE;
      }
      break;
    case GST_EVENT_FLUSH_STOP:
      if (klass->reset)
        klass->reset (filter, FALSE);
      break;
    case GST_EVENT_EOS:
      if (priv->configured && klass->reset)
        klass->reset (filter, TRUE);
      break;
    default:
      break;
  }
  return gst_pad_event_default (pad, parent, event);
}

static GstStateChangeReturn
gst_sonar_filter_change_state (GstElement * element,
    GstStateChange transition)
{
  GstStateChangeReturn ret =
      GST_ELEMENT_CLASS (gst_sonar_filter_parent_class)->change_state
      (element, transition);

  if (transition == GST_STATE_CHANGE_PAUSED_TO_READY) {
    GstSonarFilterClass *klass = GST_SONAR_FILTER_GET_CLASS (element);
    if (klass->reset)
      klass->reset (GST_SONAR_FILTER (element), FALSE);
    clear_state (GST_SONAR_FILTER (element));
  }
  return ret;
}

static void
gst_sonar_filter_finalize (GObject * object)
{
  clear_state (GST_SONAR_FILTER (object));
  G_OBJECT_CLASS (gst_sonar_filter_parent_class)->finalize (object);
}

static void
gst_sonar_filter_init (GstSonarFilter * filter)
{
}

/* The pads come from the subclass's templates: during instance init the
 * object still has the base's class, so they are made once constructed. */
static void
gst_sonar_filter_constructed (GObject * object)
{
  GstSonarFilter *filter = GST_SONAR_FILTER (object);
  GstElementClass *klass = GST_ELEMENT_GET_CLASS (filter);
  GstSonarFilterPrivate *priv = PRIV (filter);

  G_OBJECT_CLASS (gst_sonar_filter_parent_class)->constructed (object);

  priv->sinkpad = gst_pad_new_from_template
      (gst_element_class_get_pad_template (klass, "sink"), "sink");
  gst_pad_set_chain_function (priv->sinkpad, gst_sonar_filter_chain);
  gst_pad_set_event_function (priv->sinkpad, gst_sonar_filter_sink_event);
  gst_element_add_pad (GST_ELEMENT (filter), priv->sinkpad);

  priv->srcpad = gst_pad_new_from_template
      (gst_element_class_get_pad_template (klass, "src"), "src");
  gst_pad_use_fixed_caps (priv->srcpad);
  gst_element_add_pad (GST_ELEMENT (filter), priv->srcpad);
}

static void
gst_sonar_filter_class_init (GstSonarFilterClass * klass)
{
  G_OBJECT_CLASS (klass)->constructed = gst_sonar_filter_constructed;
  G_OBJECT_CLASS (klass)->finalize = gst_sonar_filter_finalize;
  GST_ELEMENT_CLASS (klass)->change_state = gst_sonar_filter_change_state;
}
