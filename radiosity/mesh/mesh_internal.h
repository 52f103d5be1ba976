/* mesh_internal.h - what the files of radiosity/mesh/ share; private to the
 * folder (the public contract is mesh.h).
 */
#ifndef RAD_MESH_INTERNAL_H
#define RAD_MESH_INTERNAL_H

#include "mesh.h"

/* How the small polygons of a scene are grouped (cluster.c).  A polygon is
 * on the cluster path when it is eligible (mesh.c: it would be one cell at
 * this patch size, and it does not transmit) and shares an edge with
 * another eligible polygon of its surface; every other polygon is meshed
 * on its own as before.  Clusters are numbered in the order of their first
 * (lowest) polygon, and list their polygons in ascending order. */
typedef struct mesh_clusters {
    uint32_t count;        /* clusters: one patch each */
    uint32_t *of;          /* polygon -> its cluster, RAD_NONE off the cluster path */
    uint32_t *first;       /* count + 1: cluster k's polygons are member[first[k] .. first[k+1]) */
    uint32_t *member;
    uint32_t *vkey;        /* scene point -> its vertex (cluster-path polygons' points only):
                            * one per surface and exact position */
    uint32_t vkeys;        /* vertices on the cluster path */
    uint8_t *vboundary;    /* per vertex: on its surface's outline */
} mesh_clusters;

/* Groups the eligible polygons (eligible[i] = 1) into clusters of about
 * `size` (the patch edge length).  *out is zeroed first; free it with
 * mesh_clusters_free.  RAD_OK or RAD_ERR_NOMEM. */
int mesh_cluster(const rad_scene *s, const uint8_t *eligible, double size, mesh_clusters *out,
                 rad_error *err);
void mesh_clusters_free(mesh_clusters *c);

#endif /* RAD_MESH_INTERNAL_H */
