/* embree.c - the ray-casting kernel of the gather renderer: Embree 3, and
 * the only file that sees it (rn_internal.h's rn_rt is all the rest of the
 * renderer knows).
 *
 * Owns one Embree device and one scene holding the cells of a rad_mesh as a
 * single quad geometry: a quad cell is its four corners, a triangle cell
 * repeats its third corner (Embree's documented encoding of a triangle as a
 * quad), so Embree's primitive id is the cell index.  Invariant: a hit
 * reported is a cell index < mesh->patch_count at a distance inside the
 * ray's (tnear, tfar); faces are two-sided here (which side was hit is the
 * caller's question, answered with the cell's own normal).  Embree works in
 * float: callers keep the distances they pass well above float rounding of
 * the scene's coordinates (final_gather.c offsets origins by 1e-6 of the
 * scene's size, about 16 float ulps of its largest coordinate).
 */
#include "rn_internal.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct rn_rt {
    RTCDevice device;
    RTCScene scene;
    uint32_t cells;
};

/* The device's first error as text, for messages. */
static const char *rt_error_name(enum RTCError e)
{
    switch (e) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    default: return "unknown error";
    }
}

int rn_rt_create(const rad_mesh *mesh, rn_rt **out, rad_error *err)
{
    *out = NULL;
    if (!mesh || mesh->patch_count == 0)
        return rad_fail(err, RAD_ERR_USAGE, "render: gather: no cells to trace");
    rn_rt *rt = calloc(1, sizeof *rt);
    if (!rt)
        return rad_fail(err, RAD_ERR_NOMEM, "render: gather: out of memory");
    rt->cells = mesh->patch_count;
    /* One build thread: the machine is shared and these scenes build in
     * milliseconds. */
    rt->device = rtcNewDevice("threads=1,verbose=0");
    if (!rt->device) {
        enum RTCError e = rtcGetDeviceError(NULL);
        free(rt);
        return rad_fail(err, e == RTC_ERROR_OUT_OF_MEMORY ? RAD_ERR_NOMEM : RAD_ERR_INVALID,
                        "render: gather: embree: cannot create a device: %s", rt_error_name(e));
    }
    rt->scene = rtcNewScene(rt->device);
    RTCGeometry g = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_QUAD);
    float *v = g ? rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                           3 * sizeof(float), mesh->vertex_count)
                 : NULL;
    unsigned *q = g ? rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                              4 * sizeof(unsigned), mesh->patch_count)
                    : NULL;
    if (!rt->scene || !v || !q) {
        enum RTCError e = rtcGetDeviceError(rt->device);
        if (g)
            rtcReleaseGeometry(g);
        rn_rt_destroy(rt);
        return rad_fail(err, RAD_ERR_NOMEM, "render: gather: embree: cannot hold %u cells: %s",
                        mesh->patch_count, rt_error_name(e));
    }
    for (uint32_t k = 0; k < mesh->vertex_count; k++) {
        v[3 * k] = (float)mesh->vertices[k].x;
        v[3 * k + 1] = (float)mesh->vertices[k].y;
        v[3 * k + 2] = (float)mesh->vertices[k].z;
    }
    for (uint32_t c = 0; c < mesh->patch_count; c++) {
        const uint32_t *pv = mesh->patches[c].v;
        q[4 * c] = pv[0];
        q[4 * c + 1] = pv[1];
        q[4 * c + 2] = pv[2];
        q[4 * c + 3] = pv[3] == RAD_NONE ? pv[2] : pv[3];
    }
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
    rtcCommitGeometry(g);
    rtcAttachGeometry(rt->scene, g);
    rtcReleaseGeometry(g);
    rtcSetSceneBuildQuality(rt->scene, RTC_BUILD_QUALITY_HIGH);
    /* Robust traversal: rays that graze a shared edge do not slip through. */
    rtcSetSceneFlags(rt->scene, RTC_SCENE_FLAG_ROBUST);
    rtcCommitScene(rt->scene);
    enum RTCError e = rtcGetDeviceError(rt->device);
    if (e != RTC_ERROR_NONE) {
        rn_rt_destroy(rt);
        return rad_fail(err, e == RTC_ERROR_OUT_OF_MEMORY ? RAD_ERR_NOMEM : RAD_ERR_INVALID,
                        "render: gather: embree: building the scene failed: %s", rt_error_name(e));
    }
    *out = rt;
    return RAD_OK;
}

void rn_rt_destroy(rn_rt *rt)
{
    if (!rt)
        return;
    if (rt->scene)
        rtcReleaseScene(rt->scene);
    if (rt->device)
        rtcReleaseDevice(rt->device);
    free(rt);
}

static void set_ray(struct RTCRay *r, rad_vec3 org, rad_vec3 dir, double tnear, double tfar)
{
    r->org_x = (float)org.x;
    r->org_y = (float)org.y;
    r->org_z = (float)org.z;
    r->dir_x = (float)dir.x;
    r->dir_y = (float)dir.y;
    r->dir_z = (float)dir.z;
    r->tnear = (float)tnear;
    r->tfar = tfar < (double)FLT_MAX ? (float)tfar : INFINITY;
    r->time = 0.0f;
    r->mask = UINT32_MAX;
    r->id = 0;
    r->flags = 0;
}

uint32_t rn_rt_intersect(const rn_rt *rt, rad_vec3 org, rad_vec3 dir, double tnear, double tfar,
                         double *t)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    set_ray(&rh.ray, org, dir, tnear, tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(rt->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || rh.hit.primID >= rt->cells)
        return RAD_NONE;
    *t = rh.ray.tfar;
    return rh.hit.primID;
}

int rn_rt_occluded(const rn_rt *rt, rad_vec3 org, rad_vec3 dir, double tnear, double tfar)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    set_ray(&r, org, dir, tnear, tfar);
    rtcOccluded1(rt->scene, &ctx, &r);
    /* Embree marks an occluded ray by setting tfar to -inf. */
    return r.tfar < 0.0f;
}
