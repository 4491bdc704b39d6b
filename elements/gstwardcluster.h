/* gstwardcluster.h: reflector centroids from the energyscape. */
#ifndef GST_WARD_CLUSTER_H
#define GST_WARD_CLUSTER_H

#include "gstsonarfilter.h"

G_BEGIN_DECLS

#define GST_TYPE_WARD_CLUSTER (gst_ward_cluster_get_type ())
G_DECLARE_FINAL_TYPE (GstWardCluster, gst_ward_cluster, GST, WARD_CLUSTER,
    GstSonarFilter)

GST_ELEMENT_REGISTER_DECLARE (wardcluster);

G_END_DECLS

#endif
