/*
 * engine_loop.c: what a game engine does with weft, frame by frame.
 *
 * - the world lives in a static block sized by WEFT_DEFAULT_WORLD_MEMORY_SIZE (checked against
 *   weft_world_memory_size at start-up);
 * - the cloth is read from, and written back to, an interleaved, packed vertex buffer (23-byte
 *   vertices, positions at byte 1: every float is unaligned) through (pointer, count, stride);
 * - a sphere and a capsule move under the cloth, and the two pinned corners follow an
 *   animated target;
 * - effects are toggled at run time (bending off and on, wind on);
 * - the cloth settles and goes to sleep, and an edit wakes it;
 * - localization: a render mesh three times finer than the cloth, in its own interleaved
 *   buffer (33-byte vertices: flag, position, normal, (u, v)), is bound once from the (u, v)
 *   in that buffer and localized into it every frame, in two ranges as two jobs would, kept
 *   outside the colliders;
 * - errors: a corrupt, a truncated and a foreign blob, a bad mesh, a too-small capacity, an
 *   uninitialized def, a NULL argument, and localization's own: each is reported with its
 *   detail;
 * - the last frame of the localized render mesh is written as an OBJ (argv[2]).
 *
 *   cc -std=c11 -I include c_examples/engine_loop.c target/ship/libweft.a -o engine_loop
 *   ./engine_loop cells.weft last_frame.obj
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "weft.h"

#define N 12                 /* vertices along each side of the cloth */
#define SIDE 0.6f            /* metres */
#define VERTS (N * N)
#define TRIS (2 * (N - 1) * (N - 1))
#define STRIDE 23            /* bytes per vertex in the render buffer */
#define POS_AT 1             /* byte offset of the position inside a vertex */
#define UV_AT 13             /* byte offset of the (u, v) inside a vertex */
#define DT (1.0f / 60.0f)

/* The render mesh: a grid three times finer than the cloth, over the same (u, v). */
#define FN (3 * (N - 1) + 1)
#define FVERTS (FN * FN)
#define FTRIS (2 * (FN - 1) * (FN - 1))
#define FSTRIDE 33           /* bytes per render vertex: flag, position, normal, (u, v) */
#define FPOS_AT 1
#define FNRM_AT 13
#define FUV_AT 25
#define FLAG 0xa5

/* The engine's render vertex buffer: packed, interleaved, nothing aligned. */
static unsigned char vertex_buffer[VERTS * STRIDE];
static uint32_t indices[3 * TRIS];
/* The world's home: static memory, aligned as weft requires. */
static _Alignas(WEFT_WORLD_MEMORY_ALIGN) unsigned char world_memory[WEFT_DEFAULT_WORLD_MEMORY_SIZE];
/* The render mesh, its bindings (made once) and the per-frame coarse frames: static too, sized
 * by the header's formulas (checked against the size queries at start-up). */
static unsigned char fine_buffer[FVERTS * FSTRIDE];
static uint32_t fine_indices[3 * FTRIS];
static uint32_t bindings[(WEFT_BIND_HEADER_SIZE + WEFT_BIND_VERTEX_SIZE * FVERTS) / 4];
static _Alignas(WEFT_LOCALIZE_FRAMES_ALIGN) unsigned char
    frames[WEFT_LOCALIZE_FRAMES_HEADER_SIZE + WEFT_LOCALIZE_FRAME_SIZE * VERTS];

static int errors_seen = 0;

static WeftVec3 vec3(float x, float y, float z)
{
    WeftVec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

static void report(const char *what, WeftResult r, const WeftErrorDetail *d)
{
    printf("%s: %s", what, weft_result_string(r));
    if (d != NULL) {
        if (d->triangle != WEFT_NONE)
            printf(" [triangle %u]", (unsigned)d->triangle);
        if (d->vertex != WEFT_NONE)
            printf(" [vertex %u]", (unsigned)d->vertex);
        if (d->needed != WEFT_NONE)
            printf(" [needed %u]", (unsigned)d->needed);
        if (d->capacity != WEFT_NONE)
            printf(" [capacity %u]", (unsigned)d->capacity);
        if (d->material != WEFT_NONE)
            printf(" [material %u]", (unsigned)d->material);
        if (d->cell != WEFT_NONE)
            printf(" [cell %u]", (unsigned)d->cell);
        if (d->what[0] != '\0')
            printf(" [%s]", d->what);
    }
    printf("\n");
}

/* An expected failure: reports it, and counts it as a test failure if the result differs. */
static void expect(const char *what, WeftResult got, WeftResult want, const WeftErrorDetail *d)
{
    report(what, got, d);
    if (got != want) {
        printf("  UNEXPECTED: wanted %s\n", weft_result_string(want));
        ++errors_seen;
    }
}

/* A call that must succeed in this program. */
#define MUST(call)                                                                  \
    do {                                                                            \
        WeftResult must_r = (call);                                                 \
        if (must_r != WEFT_RESULT_OK) {                                             \
            fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call,           \
                    weft_result_string(must_r));                                    \
            exit(1);                                                                \
        }                                                                           \
    } while (0)

static float absf(float x) { return x < 0.0f ? -x : x; }

/* A periodic wave going 0 -> 1 -> 0 over each unit of t >= 0 (no libm needed). */
static float wave(float t)
{
    float x = t - (float)(long)t; /* fractional part */
    return 4.0f * x * (1.0f - x);
}

/* Where the colliders are at time t (seconds): they sweep under the cloth for 4 s, never
 * closer than 5 cm to each other (cloth squeezed between two colliders has no solution; see
 * the README's limits: it showed here as one-frame speed spikes of up to 5 m/s). */
static WeftShape sphere_at(float t)
{
    return weft_shape_sphere(vec3(-0.25f + 0.05f * t, 0.05f * wave(t), 0.15f), 0.12f);
}

static WeftShape capsule_at(float t)
{
    return weft_shape_capsule(vec3(0.22f, -0.3f, 0.2f + 0.05f * wave(t)),
                              vec3(0.22f + 0.05f * wave(0.5f * t), 0.3f, 0.2f), 0.05f);
}

static void *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    void *bytes = NULL;
    long n;
    if (f == NULL)
        return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) > 0 && fseek(f, 0, SEEK_SET) == 0) {
        bytes = malloc((size_t)n);
        if (bytes != NULL && fread(bytes, 1, (size_t)n, f) != (size_t)n) {
            free(bytes);
            bytes = NULL;
        }
        *size = (size_t)n;
    }
    fclose(f);
    return bytes;
}

static void put_vec(unsigned char *at, float x, float y, float z)
{
    float v[3];
    v[0] = x;
    v[1] = y;
    v[2] = z;
    memcpy(at, v, sizeof v);
}

static WeftVec3 get_pos(uint32_t vertex)
{
    WeftVec3 p;
    memcpy(&p, vertex_buffer + (size_t)vertex * STRIDE + POS_AT, sizeof p);
    return p;
}


/* Fills the render buffer with a flat cloth at height z, hanging in the x-y plane. */
static void build_mesh(float z)
{
    int i, j, t = 0;
    for (j = 0; j < N; ++j) {
        for (i = 0; i < N; ++i) {
            unsigned char *v = vertex_buffer + (size_t)(j * N + i) * STRIDE;
            float u = SIDE * (float)i / (N - 1) - 0.5f * SIDE, w = SIDE * (float)j / (N - 1);
            float uv[2];
            v[0] = 0x5a; /* an engine flag byte */
            put_vec(v + POS_AT, u, w - 0.5f * SIDE, z);
            uv[0] = u + 0.5f * SIDE;
            uv[1] = w;
            memcpy(v + UV_AT, uv, sizeof uv);
        }
    }
    for (j = 0; j < N - 1; ++j) {
        for (i = 0; i < N - 1; ++i) {
            uint32_t ll = (uint32_t)(j * N + i), lr = ll + 1, ul = ll + N, ur = ul + 1;
            indices[t++] = ll;
            indices[t++] = lr;
            indices[t++] = ur;
            indices[t++] = ll;
            indices[t++] = ur;
            indices[t++] = ul;
        }
    }
}

static WeftVec3 get_fine(uint32_t vertex, int at)
{
    WeftVec3 p;
    memcpy(&p, fine_buffer + (size_t)vertex * FSTRIDE + at, sizeof p);
    return p;
}

/* The render mesh: flag bytes and (u, v) set once; weft writes positions and normals. */
static void build_fine_mesh(void)
{
    int i, j, t = 0;
    for (j = 0; j < FN; ++j) {
        for (i = 0; i < FN; ++i) {
            unsigned char *v = fine_buffer + (size_t)(j * FN + i) * FSTRIDE;
            float uv[2];
            v[0] = FLAG;
            uv[0] = SIDE * (float)i / (FN - 1);
            uv[1] = SIDE * (float)j / (FN - 1);
            memcpy(v + FUV_AT, uv, sizeof uv);
        }
    }
    for (j = 0; j < FN - 1; ++j) {
        for (i = 0; i < FN - 1; ++i) {
            uint32_t ll = (uint32_t)(j * FN + i), lr = ll + 1, ul = ll + FN, ur = ul + 1;
            fine_indices[t++] = ll;
            fine_indices[t++] = lr;
            fine_indices[t++] = ur;
            fine_indices[t++] = ll;
            fine_indices[t++] = ur;
            fine_indices[t++] = ul;
        }
    }
}

/* Where localization writes: fine vertices first .. first + count of the render buffer. */
static WeftLocalizeOutput fine_output(uint32_t first)
{
    WeftLocalizeOutput out = weft_default_localize_output();
    out.positions = fine_buffer + (size_t)first * FSTRIDE + FPOS_AT;
    out.position_stride = FSTRIDE;
    out.normals = fine_buffer + (size_t)first * FSTRIDE + FNRM_AT;
    out.normal_stride = FSTRIDE;
    out.normal_mode = WEFT_NORMALS_BLENDED;
    /* The render mesh stays outside the sphere and the capsule the cloth drapes over (between
     * the cloth's vertices it would otherwise cut into them). */
    out.collider_mode = WEFT_COLLIDERS_OUTSIDE;
    return out;
}

/* Every frame after the step: measure the coarse cloth once, then localize the render mesh in
 * two ranges, as two jobs of an engine's job system would (any split works; the calls only
 * read the world, the frames and the bindings, so they may run on two threads at once). */
static void localize_frame(const WeftWorld *world)
{
    uint32_t first, half = FVERTS / 2;
    MUST(weft_localize_prepare(world, WEFT_STRAIN_COROTATED, frames, sizeof frames, NULL));
    for (first = 0; first < FVERTS; first += half) {
        uint32_t count = first + half <= FVERTS ? half : FVERTS - first;
        WeftLocalizeOutput out = fine_output(first);
        MUST(weft_localize(world, frames, bindings, sizeof bindings, first, count, &out, NULL));
    }
}

/* Localization's errors, each reported with its detail; none writes an output. */
static void localize_errors(const WeftWorld *world)
{
    static uint32_t small[(WEFT_BIND_HEADER_SIZE + WEFT_BIND_VERTEX_SIZE * 6) / 4];
    static unsigned char before[sizeof fine_buffer];
    WeftErrorDetail d;
    WeftLocalizeOutput out = fine_output(0);
    float outside[2 * 6] = {0.1f, 0.1f, 0.2f, 0.2f, 0.3f, 0.3f, 0.4f, 0.4f, -0.1f, 0.5f, 0.5f, 0.5f};

    memcpy(before, fine_buffer, sizeof before);
    /* Before the first prepare there are no frames to localize from. */
    expect("unprepared frames",
           weft_localize(world, frames, bindings, sizeof bindings, 0, FVERTS, &out, &d),
           WEFT_RESULT_FRAMES_NOT_PREPARED, &d);
    MUST(weft_localize_prepare(world, WEFT_STRAIN_COROTATED, frames, sizeof frames, NULL));
    /* A render vertex outside the cloth's (u, v): named by its index. */
    expect("outside the cloth",
           weft_bind(world, outside, 6, 2 * sizeof(float), small, sizeof small, &d),
           WEFT_RESULT_BIND_OUT_OF_DOMAIN, &d);
    if (d.vertex != 4)
        ++errors_seen;
    /* A bindings block too small for the mesh. */
    expect("small bindings",
           weft_bind(world, fine_buffer + FUV_AT, FVERTS, FSTRIDE, small, sizeof small, &d),
           WEFT_RESULT_BIND_MEMORY_TOO_SMALL, &d);
    /* Memory that bindings were never written to. */
    expect("not bindings", weft_localize(world, frames, small, sizeof small, 0, 6, &out, &d),
           WEFT_RESULT_BINDINGS_INVALID, &d);
    /* A range past the end of the mesh. */
    expect("range", weft_localize(world, frames, bindings, sizeof bindings, 1, FVERTS, &out, &d),
           WEFT_RESULT_LOCALIZE_RANGE, &d);
    /* Normals on top of the positions. */
    out.normals = fine_buffer + FPOS_AT + 4;
    expect("overlapping normals",
           weft_localize(world, frames, bindings, sizeof bindings, 0, FVERTS, &out, &d),
           WEFT_RESULT_NORMAL_LAYOUT, &d);
    /* An unknown collider mode. */
    out = fine_output(0);
    out.collider_mode = 7;
    expect("collider mode",
           weft_localize(world, frames, bindings, sizeof bindings, 0, FVERTS, &out, &d),
           WEFT_RESULT_INVALID_ARGUMENT, &d);
    /* An unknown strain measure. */
    expect("strain measure", weft_localize_prepare(world, 7, frames, sizeof frames, &d),
           WEFT_RESULT_INVALID_ARGUMENT, &d);
    if (memcmp(before, fine_buffer, sizeof before) != 0) {
        printf("  UNEXPECTED: a failed call wrote the render buffer\n");
        ++errors_seen;
    }
}

static WeftWorldDef cloth_def(void)
{
    WeftWorldDef def = weft_default_world_def();
    def.positions = vertex_buffer + POS_AT;
    def.position_stride = STRIDE;
    def.uvs = vertex_buffer + UV_AT;
    def.uv_stride = STRIDE;
    def.vertex_count = VERTS;
    def.indices = indices;
    def.triangle_count = TRIS;
    def.material = 0;
    def.settings.substeps = 2;
    return def;
}

/* Every error path an engine should handle, each reported with its detail. */
static void error_handling(const unsigned char *blob_bytes, size_t blob_size, const WeftBlob *blob)
{
    WeftErrorDetail d;
    WeftBlob bad;
    WeftWorld *w = NULL;
    WeftWorldDef def;
    unsigned char *copy = malloc(blob_size);
    uint32_t saved;
    if (copy == NULL)
        exit(1);

    /* A corrupt blob: one byte flipped in the middle. */
    memcpy(copy, blob_bytes, blob_size);
    copy[blob_size / 2] ^= 0x40;
    expect("corrupt blob", weft_blob_parse(copy, blob_size, &bad, &d), WEFT_RESULT_BLOB_CHECKSUM,
           &d);
    /* A truncated download. */
    memcpy(copy, blob_bytes, blob_size);
    expect("truncated blob", weft_blob_parse(copy, blob_size - 100, &bad, &d),
           WEFT_RESULT_BLOB_SIZE, &d);
    /* Not a blob at all. */
    memset(copy, 'x', blob_size);
    expect("foreign file", weft_blob_parse(copy, blob_size, &bad, &d), WEFT_RESULT_BLOB_BAD_MAGIC,
           &d);
    free(copy);

    /* A bad mesh: a triangle names a vertex that does not exist. */
    def = cloth_def();
    saved = indices[3 * 7 + 2];
    indices[3 * 7 + 2] = VERTS + 5;
    expect("bad mesh", weft_world_create(&def, blob, world_memory, sizeof world_memory, &w, &d),
           WEFT_RESULT_MESH_INDEX_OUT_OF_RANGE, &d);
    if (d.triangle != 7)
        ++errors_seen;
    indices[3 * 7 + 2] = saved;
    /* A triangle material that is not a cell of the blob. */
    def = cloth_def();
    def.material = blob->cell_count;
    expect("bad material", weft_world_create(&def, blob, world_memory, sizeof world_memory, &w, &d),
           WEFT_RESULT_MATERIAL_OUT_OF_RANGE, &d);
    /* A capacity too small for the mesh. */
    def = cloth_def();
    def.capacity.max_vertices = VERTS - 1;
    expect("small capacity", weft_world_create(&def, blob, world_memory, sizeof world_memory, &w, &d),
           WEFT_RESULT_VERTEX_CAPACITY, &d);
    if (d.needed != VERTS || d.capacity != VERTS - 1)
        ++errors_seen;
    /* A setting out of range. */
    def = cloth_def();
    def.settings.substeps = 0;
    expect("bad setting", weft_world_create(&def, blob, world_memory, sizeof world_memory, &w, &d),
           WEFT_RESULT_INVALID_SETTING, &d);
    /* A def that did not come from weft_default_world_def. */
    memset(&def, 0, sizeof def);
    expect("uninitialized def",
           weft_world_create(&def, blob, world_memory, sizeof world_memory, &w, &d),
           WEFT_RESULT_UNINITIALIZED, &d);
    /* Too little memory, and a NULL out-pointer. */
    def = cloth_def();
    expect("small memory", weft_world_create(&def, blob, world_memory, 4096, &w, &d),
           WEFT_RESULT_MEMORY_TOO_SMALL, &d);
    expect("NULL out_world",
           weft_world_create(&def, blob, world_memory, sizeof world_memory, NULL, &d),
           WEFT_RESULT_NULL_POINTER, &d);
    if (w != NULL) {
        printf("  UNEXPECTED: a failed create wrote its output\n");
        ++errors_seen;
    }
}

static void write_obj(const char *path)
{
    FILE *f = fopen(path, "w");
    int i;
    if (f == NULL) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    /* The render buffer holds the last frame's localized mesh: write it as it would be drawn. */
    fprintf(f, "# weft engine_loop: the localized render mesh, last frame\n");
    for (i = 0; i < FVERTS; ++i) {
        WeftVec3 p = get_fine((uint32_t)i, FPOS_AT);
        fprintf(f, "v %.6f %.6f %.6f\n", (double)p.x, (double)p.y, (double)p.z);
    }
    for (i = 0; i < FVERTS; ++i) {
        WeftVec3 n = get_fine((uint32_t)i, FNRM_AT);
        fprintf(f, "vn %.6f %.6f %.6f\n", (double)n.x, (double)n.y, (double)n.z);
    }
    for (i = 0; i < FTRIS; ++i) {
        unsigned a = (unsigned)fine_indices[3 * i] + 1, b = (unsigned)fine_indices[3 * i + 1] + 1,
                 c = (unsigned)fine_indices[3 * i + 2] + 1;
        fprintf(f, "f %u//%u %u//%u %u//%u\n", a, a, b, b, c, c);
    }
    fclose(f);
    printf("wrote %s (%d vertices, %d triangles)\n", path, FVERTS, FTRIS);
}

int main(int argc, char **argv)
{
    unsigned char *bytes;
    size_t blob_size = 0, needed = 0, fine_needed = 0;
    WeftBlob blob;
    WeftErrorDetail d;
    WeftWorldDef def;
    WeftWorld *world = NULL;
    WeftColliderDef cdef;
    WeftSettings settings;
    WeftStepStats stats;
    uint32_t sphere, capsule, corner_a = VERTS - N, corner_b = VERTS - 1;
    WeftVec3 anchor_a, anchor_b;
    int frame, asleep_at = -1, max_contacts = 0;
    float max_speed2 = 0.0f;

    if (argc < 3) {
        fprintf(stderr, "usage: %s CELLS.weft OUT.obj\n", argv[0]);
        return 2;
    }
    bytes = read_file(argv[1], &blob_size);
    if (bytes == NULL) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 1;
    }
    if (weft_blob_parse(bytes, blob_size, &blob, &d) != WEFT_RESULT_OK) {
        report("blob", d.result, &d);
        return 1;
    }

    /* The static block must be big enough for the capacity we use. */
    build_mesh(0.5f);
    def = cloth_def();
    MUST(weft_world_memory_size(&def.capacity, &needed, NULL));
    printf("world memory: %zu bytes needed, %zu reserved\n", needed, sizeof world_memory);
    if (needed > sizeof world_memory)
        return 1;
    MUST(weft_bind_memory_size(FVERTS, &fine_needed, NULL));
    if (fine_needed != sizeof bindings)
        return 1;

    error_handling(bytes, blob_size, &blob);

    /* The real world. A failed create above left the block free for this. */
    build_mesh(0.5f);
    def = cloth_def();
    def.settings.effects |= WEFT_EFFECT_SLEEP;
    if (weft_world_create(&def, &blob, world_memory, sizeof world_memory, &world, &d) !=
        WEFT_RESULT_OK) {
        report("create", d.result, &d);
        return 1;
    }

    /* The render mesh: bound once, from the (u, v) inside its own interleaved buffer. */
    build_fine_mesh();
    MUST(weft_localize_frames_size(world, &fine_needed, NULL));
    if (fine_needed != sizeof frames)
        return 1;
    if (weft_bind(world, fine_buffer + FUV_AT, FVERTS, FSTRIDE, bindings, sizeof bindings, &d) !=
        WEFT_RESULT_OK) {
        report("bind", d.result, &d);
        return 1;
    }
    printf("render mesh: %d vertices, %d triangles, %zu bytes of bindings, %zu bytes of frames\n",
           FVERTS, FTRIS, sizeof bindings, sizeof frames);
    localize_errors(world);

    /* Colliders: the floor, a sphere and a capsule that move under the cloth. */
    cdef = weft_default_collider_def();
    cdef.shape = weft_shape_plane(vec3(0.0f, 0.0f, 1.0f), -0.4f);
    MUST(weft_world_add_collider(world, &cdef, NULL, NULL));
    cdef.shape = sphere_at(0.0f);
    cdef.friction = 0.3f;
    MUST(weft_world_add_collider(world, &cdef, &sphere, NULL));
    cdef.shape = capsule_at(0.0f);
    MUST(weft_world_add_collider(world, &cdef, &capsule, NULL));

    /* Pins: the two far corners, driven by an animated anchor. */
    anchor_a = get_pos(corner_a);
    anchor_b = get_pos(corner_b);
    MUST(weft_world_set_pin(world, corner_a, anchor_a, NULL));
    MUST(weft_world_set_pin(world, corner_b, anchor_b, NULL));

    for (frame = 1; frame <= 900; ++frame) {
        float t = (float)frame * DT;
        WeftResult r;
        if (frame <= 240) {
            /* Animate: the anchor sways along x, the colliders move. */
            float sway = 0.1f * wave(0.5f * t);
            WeftShape s = sphere_at(t);
            MUST(weft_world_set_pin(world, corner_a, vec3(anchor_a.x + sway, anchor_a.y, anchor_a.z), NULL));
            MUST(weft_world_set_pin(world, corner_b, vec3(anchor_b.x + sway, anchor_b.y, anchor_b.z), NULL));
            MUST(weft_world_set_collider(world, sphere, &s, NULL));
            s = capsule_at(t);
            MUST(weft_world_set_collider(world, capsule, &s, NULL));
        }
        /* Effects change at run time. */
        if (frame == 60) {
            MUST(weft_world_get_settings(world, &settings, NULL));
            MUST(weft_world_set_effects(world, settings.effects & ~WEFT_EFFECT_BENDING, NULL));
            printf("frame %d: bending off\n", frame);
        }
        if (frame == 120) {
            MUST(weft_world_get_settings(world, &settings, NULL));
            settings.effects |= WEFT_EFFECT_BENDING | WEFT_EFFECT_WIND;
            settings.wind = vec3(2.0f, 0.0f, 0.0f);
            settings.drag = 0.5f;
            MUST(weft_world_set_settings(world, &settings, NULL));
            printf("frame %d: bending on, wind on\n", frame);
        }
        if (frame == 241) {
            /* Calm down: no wind, colliders away, more damping, so the cloth can sleep. */
            MUST(weft_world_clear_colliders(world, NULL));
            MUST(weft_world_get_settings(world, &settings, NULL));
            settings.effects &= ~WEFT_EFFECT_WIND;
            settings.damping_mass = 3.0f;
            settings.sleep_velocity = 0.01f;
            settings.sleep_frames = 10;
            MUST(weft_world_set_settings(world, &settings, NULL));
            printf("frame %d: colliders cleared, wind off, settling\n", frame);
        }
        r = weft_world_step(world, DT, &stats, &d);
        if (r != WEFT_RESULT_OK) {
            report("step", r, &d);
            return 1;
        }
        if ((int)stats.contacts > max_contacts)
            max_contacts = (int)stats.contacts;
        /* A sanity check an engine may afford: nothing moves faster than 20 m/s. */
        {
            static WeftVec3 v[VERTS];
            int i;
            MUST(weft_world_get_velocities(world, v, VERTS, sizeof(WeftVec3), NULL));
            for (i = 0; i < VERTS; ++i) {
                float s2 = v[i].x * v[i].x + v[i].y * v[i].y + v[i].z * v[i].z;
                if (s2 > max_speed2)
                    max_speed2 = s2;
            }
            if (!(max_speed2 < 400.0f)) {
                printf("frame %d: the cloth exploded (speed^2 %g)\n", frame, (double)max_speed2);
                return 1;
            }
        }
        /* The engine's buffers get the new positions, in place: the cloth's own, and the
         * localized render mesh. */
        MUST(weft_world_get_positions(world, vertex_buffer + POS_AT, VERTS, STRIDE, NULL));
        localize_frame(world);
        if (asleep_at < 0 && weft_world_is_asleep(world)) {
            asleep_at = frame;
            printf("frame %d: asleep\n", frame);
            break;
        }
    }
    printf("most contacts in a frame: %d, top speed^2 %.3g m^2/s^2\n", max_contacts, (double)max_speed2);
    if (asleep_at < 0) {
        printf("never fell asleep\n");
        return 1;
    }
    MUST(weft_world_step(world, DT, &stats, NULL));
    printf("asleep step: %s, %u substeps\n", stats.asleep ? "skipped" : "ran", (unsigned)stats.substeps);
    /* Pulling a pin wakes it. */
    MUST(weft_world_set_pin(world, corner_a, vec3(anchor_a.x, anchor_a.y, anchor_a.z + 0.05f), NULL));
    MUST(weft_world_step(world, DT, &stats, NULL));
    printf("after moving a pin: %s\n", weft_world_is_asleep(world) ? "asleep" : "awake");
    if (weft_world_is_asleep(world) || stats.asleep)
        ++errors_seen;

    /* Runtime errors are reported too; the world stays usable. */
    expect("pin out of range", weft_world_set_pin(world, VERTS, anchor_a, &d), WEFT_RESULT_VERTEX_OUT_OF_RANGE, &d);
    if (d.vertex != VERTS)
        ++errors_seen;
    expect("zero dt", weft_world_step(world, 0.0f, NULL, NULL), WEFT_RESULT_INVALID_TIME_STEP, NULL);
    expect("short buffer", weft_world_get_positions(world, vertex_buffer + POS_AT, VERTS - 1, STRIDE, NULL),
           WEFT_RESULT_COUNT_MISMATCH, NULL);
    expect("overlapping stride", weft_world_get_positions(world, vertex_buffer, VERTS, 8, NULL),
           WEFT_RESULT_INVALID_ARGUMENT, NULL);
    expect("unknown effect bit", weft_world_set_effects(world, 1u << 30, NULL), WEFT_RESULT_INVALID_SETTING, NULL);

    {
        /* The pinned corner is on its target; nothing went through the floor. */
        WeftVec3 a = get_pos(corner_a);
        float lowest = 1.0f;
        int i;
        MUST(weft_world_get_positions(world, vertex_buffer + POS_AT, VERTS, STRIDE, NULL));
        a = get_pos(corner_a);
        for (i = 0; i < VERTS; ++i) {
            WeftVec3 p = get_pos((uint32_t)i);
            if (p.z < lowest)
                lowest = p.z;
            if (vertex_buffer[(size_t)i * STRIDE] != 0x5a) {
                printf("weft wrote outside the position bytes of vertex %d\n", i);
                ++errors_seen;
            }
        }
        printf("pinned corner z = %.4f, lowest z = %.4f\n", (double)a.z, (double)lowest);
        if (absf(a.z - (anchor_a.z + 0.05f)) > 1e-4f || lowest < -0.4f - 1e-3f)
            ++errors_seen;
    }

    {
        /* The render mesh covers the cloth: every third render vertex sits on a cloth vertex
         * (same (u, v)) and lands there, up to the pattern's micro displacement. Normals are
         * unit length, and weft wrote nothing but positions and normals. */
        float worst = 0.0f, worst_normal = 0.0f;
        int i, j, k;
        localize_frame(world);
        for (j = 0; j < N; ++j) {
            for (i = 0; i < N; ++i) {
                WeftVec3 c = get_pos((uint32_t)(j * N + i));
                WeftVec3 f = get_fine((uint32_t)(3 * j * FN + 3 * i), FPOS_AT);
                float gap[3];
                gap[0] = absf(f.x - c.x);
                gap[1] = absf(f.y - c.y);
                gap[2] = absf(f.z - c.z);
                for (k = 0; k < 3; ++k)
                    if (!(gap[k] <= worst))
                        worst = gap[k];
            }
        }
        for (i = 0; i < FVERTS; ++i) {
            WeftVec3 n = get_fine((uint32_t)i, FNRM_AT);
            float e = absf(n.x * n.x + n.y * n.y + n.z * n.z - 1.0f);
            float uv[2];
            if (!(e <= worst_normal))
                worst_normal = e;
            memcpy(uv, fine_buffer + (size_t)i * FSTRIDE + FUV_AT, sizeof uv);
            if (fine_buffer[(size_t)i * FSTRIDE] != FLAG ||
                uv[0] != SIDE * (float)(i % FN) / (FN - 1) ||
                uv[1] != SIDE * (float)(i / FN) / (FN - 1)) {
                printf("weft wrote outside the position and normal of render vertex %d\n", i);
                ++errors_seen;
                break;
            }
        }
        printf("render vertices on cloth vertices: %.4f mm away at most; normals unit to %.1e\n",
               (double)(1000.0f * worst), (double)worst_normal);
        if (!(worst < 1e-3f) || !(worst_normal < 1e-5f))
            ++errors_seen;
    }
    write_obj(argv[2]);
    MUST(weft_world_destroy(world, NULL));
    expect("destroyed handle", weft_world_step(world, DT, NULL, NULL), WEFT_RESULT_INVALID_HANDLE, NULL);
    free(bytes);
    if (errors_seen != 0) {
        printf("engine_loop: %d unexpected results\n", errors_seen);
        return 1;
    }
    printf("engine_loop: ok\n");
    return 0;
}
