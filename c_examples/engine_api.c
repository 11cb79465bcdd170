/*
 * engine_api.c: the calls an engine reaches for beyond create and step, each checked against
 * what it must do.
 *
 * - forces, impulses and per-vertex mass scales (a heavier hem);
 * - a curtain on rings that slide along an inclined rail (pins that hold some directions);
 * - a range of vertices in and out, and a rigid teleport that keeps the shape and motion;
 * - colliders removed one at a time by id, and the engine's pointer on the world;
 * - per-triangle strain read back (for tearing or shading);
 * - a cloth that could never step ((u, v) in the wrong units) refused at create;
 *
 *   cc -std=c11 -I include c_examples/engine_api.c target/ship/libweft.a -o engine_api
 *   ./engine_api cells.weft
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "weft.h"

#define N 8
#define SIDE 0.4f
#define VERTS (N * N)
#define TRIS (2 * (N - 1) * (N - 1))
#define DT (1.0f / 60.0f)

static WeftVec3 positions[VERTS];
static WeftVec2 uvs[VERTS];
static uint32_t indices[3 * TRIS];
static int failures = 0;

/* Runs a call that must succeed; prints its result and detail otherwise. */
#define MUST(call)                                                                         \
    do {                                                                                   \
        WeftResult must_r = (call);                                                        \
        if (must_r != WEFT_RESULT_OK) {                                                    \
            printf("FAILED %s: %s\n", #call, weft_result_string(must_r));                  \
            ++failures;                                                                    \
        }                                                                                  \
    } while (0)

/* A condition that must hold. */
static void check(int ok, const char *what, double value)
{
    printf("%s: %s (%.6g)\n", what, ok ? "ok" : "WRONG", value);
    failures += !ok;
}

/* Reads a whole file into malloc'd memory (malloc is aligned enough for WEFT_BLOB_ALIGN). */
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

/* A flat N x N sheet in the x-z plane (a curtain), its (u, v) its layout. */
static void make_sheet(void)
{
    int i, j, t = 0;
    for (j = 0; j < N; ++j) {
        for (i = 0; i < N; ++i) {
            float u = SIDE * (float)i / (N - 1), v = SIDE * (float)j / (N - 1);
            positions[j * N + i].x = u;
            positions[j * N + i].y = 0.0f;
            positions[j * N + i].z = v;
            uvs[j * N + i].x = u;
            uvs[j * N + i].y = v;
        }
    }
    for (j = 0; j < N - 1; ++j) {
        for (i = 0; i < N - 1; ++i) {
            uint32_t ll = (uint32_t)(j * N + i), lr = ll + 1, ul = ll + N, ur = ul + 1;
            uint32_t quad[6] = {ll, lr, ur, ll, ur, ul};
            memcpy(&indices[t], quad, sizeof quad);
            t += 6;
        }
    }
}

/* Σ m v (kg m/s). */
static WeftVec3 momentum(const WeftWorld *world)
{
    static WeftVec3 v[VERTS];
    static float m[VERTS];
    WeftVec3 p = {0.0f, 0.0f, 0.0f};
    int i;
    MUST(weft_world_get_velocities(world, v, VERTS, sizeof(WeftVec3), NULL));
    MUST(weft_world_get_masses(world, 0, VERTS, m, sizeof(float), NULL));
    for (i = 0; i < VERTS; ++i) {
        p.x += m[i] * v[i].x;
        p.y += m[i] * v[i].y;
        p.z += m[i] * v[i].z;
    }
    return p;
}

/* Forces for one step, impulses at once, and a heavier hem. */
static void forces_impulses_masses(WeftWorld *world)
{
    static float rest[VERTS], scaled[VERTS];
    /* interleaved {force, tag}: the forces are read at a stride of 16 bytes */
    static struct {
        WeftVec3 force;
        float tag;
    } push[VERTS];
    float hem[N];
    WeftVec3 p0, p1, kick = {0.0f, 0.002f, 0.0f};
    int i;

    p0 = momentum(world);
    for (i = 0; i < VERTS; ++i) {
        push[i].force.x = 0.001f * (float)(i % 5);
        push[i].force.y = 0.0f;
        push[i].force.z = 0.0f;
        push[i].tag = -1.0f;
    }
    MUST(weft_world_add_forces(world, 0, VERTS, &push[0].force, sizeof push[0], NULL));
    MUST(weft_world_step(world, DT, NULL, NULL));
    p1 = momentum(world);
    /* Σ F dt = 64 / 5 * (0 + 1 + 2 + 3 + 4) mN ... exactly: */
    {
        float total = 0.0f;
        for (i = 0; i < VERTS; ++i)
            total += push[i].force.x;
        check(fabsf(p1.x - p0.x - total * DT) < 1e-3f * total * DT,
              "a force changes the momentum by F dt", (double)(p1.x - p0.x));
    }
    /* cleared after the step: the next one keeps the momentum */
    MUST(weft_world_step(world, DT, NULL, NULL));
    check(fabsf(momentum(world).x - p1.x) < 1e-3f * fabsf(p1.x), "forces last one step",
          (double)momentum(world).x);

    /* an impulse on vertex 10: Δp = J */
    p0 = momentum(world);
    MUST(weft_world_add_impulses(world, 10, 1, &kick, sizeof kick, NULL));
    p1 = momentum(world);
    check(fabsf(p1.y - p0.y - kick.y) < 1e-6f, "an impulse changes the momentum by J",
          (double)(p1.y - p0.y));

    /* a hem three times heavier: the bottom row */
    MUST(weft_world_get_masses(world, 0, VERTS, rest, sizeof(float), NULL));
    for (i = 0; i < N; ++i)
        hem[i] = 3.0f;
    MUST(weft_world_set_mass_scales(world, 0, N, hem, sizeof(float), NULL));
    MUST(weft_world_get_masses(world, 0, VERTS, scaled, sizeof(float), NULL));
    check(scaled[0] == 3.0f * rest[0] && scaled[N] == rest[N], "a heavier hem",
          (double)(scaled[0] / rest[0]));
    hem[2] = 0.0f;
    check(weft_world_set_mass_scales(world, 0, N, hem, sizeof(float), NULL) ==
              WEFT_RESULT_INVALID_ARGUMENT,
          "a zero mass scale is refused", 0.0);
    check(weft_world_add_forces(world, VERTS - 1, 2, push, sizeof push[0], NULL) ==
              WEFT_RESULT_VERTEX_OUT_OF_RANGE,
          "forces past the last vertex are refused", 0.0);
}

/* The top row on rings along a rail inclined by 0.3 rad: the rail pushes only across itself
 * and every other force is internal (damping is off), so the momentum along it grows at
 * M g sin(0.3) exactly, however the curtain swings. */
static void curtain_on_a_rail(WeftWorld *world)
{
    static float m[VERTS];
    static WeftVec3 x[VERTS];
    const float theta = 0.3f, g = 9.81f;
    WeftVec3 rail = {cosf(theta), 0.0f, -sinf(theta)}, zero = {0.0f, 0.0f, 0.0f}, p0, p1;
    WeftSettings settings;
    float mass = 0.0f, along;
    int i, frames = 30;

    MUST(weft_world_get_settings(world, &settings, NULL));
    settings.effects |= WEFT_EFFECT_GRAVITY;
    MUST(weft_world_set_settings(world, &settings, NULL));
    MUST(weft_world_get_masses(world, 0, VERTS, m, sizeof(float), NULL));
    for (i = 0; i < VERTS; ++i)
        mass += m[i];
    /* (the rings where they are: the cloth drifted in the first test) */
    MUST(weft_world_get_positions(world, x, VERTS, sizeof(WeftVec3), NULL));
    for (i = 0; i < N; ++i) {
        uint32_t ring = (uint32_t)((N - 1) * N + i);
        MUST(weft_world_set_pin_line(world, ring, x[ring], rail, NULL));
    }
    p0 = momentum(world);
    for (i = 0; i < frames; ++i)
        MUST(weft_world_step(world, DT, NULL, NULL));
    p1 = momentum(world);
    along = (p1.x - p0.x) * rail.x + (p1.z - p0.z) * rail.z;
    check(fabsf(along - mass * g * sinf(theta) * DT * (float)frames) <
              2e-3f * mass * g * sinf(theta) * DT * (float)frames,
          "the curtain slides along its rail at g sin(theta)", (double)along);
    check(weft_world_set_pin_line(world, 0, positions[0], zero, NULL) == WEFT_RESULT_INVALID_ARGUMENT,
          "a rail without a direction is refused", 0.0);
}

/* The longest relative change of an edge length between two sets of positions. */
static float shape_change(const WeftVec3 *a, const WeftVec3 *b)
{
    float worst = 0.0f;
    int t, k;
    for (t = 0; t < TRIS; ++t) {
        for (k = 0; k < 3; ++k) {
            uint32_t i = indices[3 * t + k], j = indices[3 * t + (k + 1) % 3];
            float la = sqrtf((a[i].x - a[j].x) * (a[i].x - a[j].x) +
                             (a[i].y - a[j].y) * (a[i].y - a[j].y) +
                             (a[i].z - a[j].z) * (a[i].z - a[j].z));
            float lb = sqrtf((b[i].x - b[j].x) * (b[i].x - b[j].x) +
                             (b[i].y - b[j].y) * (b[i].y - b[j].y) +
                             (b[i].z - b[j].z) * (b[i].z - b[j].z));
            if (fabsf(lb - la) > worst * la)
                worst = fabsf(lb - la) / la;
        }
    }
    return worst;
}

/* A range of vertices in and out, then the whole cloth turned by 90 degrees about z and moved
 * 10 m away with its motion. */
static void ranges_and_teleport(WeftWorld *world)
{
    static WeftVec3 before[VERTS], after[VERTS], v0[VERTS], v1[VERTS];
    WeftVec3 row[N], back[N];
    WeftQuat quarter = {0.0f, 0.0f, 0.70710678f, 0.70710678f};
    WeftVec3 away = {10.0f, 0.0f, 0.0f};
    float speed0 = 0.0f, speed1 = 0.0f;
    int i;

    /* the second row, lifted by 1 cm, and read back */
    MUST(weft_world_get_positions_range(world, N, N, row, sizeof(WeftVec3), NULL));
    for (i = 0; i < N; ++i)
        row[i].y += 0.01f;
    MUST(weft_world_set_positions_range(world, N, N, row, sizeof(WeftVec3), NULL));
    MUST(weft_world_get_positions_range(world, N, N, back, sizeof(WeftVec3), NULL));
    check(memcmp(row, back, sizeof row) == 0, "a range of positions round-trips", 0.0);
    check(weft_world_get_positions_range(world, VERTS - 1, 2, back, sizeof(WeftVec3), NULL) ==
              WEFT_RESULT_VERTEX_OUT_OF_RANGE,
          "a range past the last vertex is refused", 0.0);

    MUST(weft_world_get_positions(world, before, VERTS, sizeof(WeftVec3), NULL));
    MUST(weft_world_get_velocities(world, v0, VERTS, sizeof(WeftVec3), NULL));
    MUST(weft_world_transform(world, quarter, away, 1, NULL));
    MUST(weft_world_get_positions(world, after, VERTS, sizeof(WeftVec3), NULL));
    MUST(weft_world_get_velocities(world, v1, VERTS, sizeof(WeftVec3), NULL));
    for (i = 0; i < VERTS; ++i) {
        speed0 += sqrtf(v0[i].x * v0[i].x + v0[i].y * v0[i].y + v0[i].z * v0[i].z);
        speed1 += sqrtf(v1[i].x * v1[i].x + v1[i].y * v1[i].y + v1[i].z * v1[i].z);
    }
    check(shape_change(before, after) < 1e-5f, "a teleport keeps the shape",
          (double)shape_change(before, after));
    check(fabsf(after[0].x - (10.0f - before[0].y)) < 1e-5f && fabsf(after[0].y - before[0].x) < 1e-5f,
          "a teleport turns and moves", (double)after[0].x);
    check(fabsf(speed1 - speed0) < 1e-5f * speed0 && fabsf(v1[5].y - v0[5].x) < 1e-6f,
          "a teleport turns the velocities", (double)speed1);
    MUST(weft_world_step(world, DT, NULL, NULL));
    check(weft_world_transform(world, quarter, away, 2, NULL) == WEFT_RESULT_INVALID_ARGUMENT,
          "keep_velocity is 0 or 1", 0.0);
}

/* Three colliders; the first removed: the others keep their ids, the removed one is refused. */
static void collider_ids_and_user_data(WeftWorld *world)
{
    static int owner = 42;
    WeftColliderDef def = weft_default_collider_def();
    WeftShape far_away = weft_shape_sphere((WeftVec3){0.0f, 50.0f, 0.0f}, 0.1f);
    uint32_t a, b, c, d;

    def.shape = far_away;
    MUST(weft_world_add_collider(world, &def, &a, NULL));
    def.shape = weft_shape_plane((WeftVec3){0.0f, 0.0f, 1.0f}, -5.0f);
    MUST(weft_world_add_collider(world, &def, &b, NULL));
    def.shape = far_away;
    MUST(weft_world_add_collider(world, &def, &c, NULL));
    MUST(weft_world_remove_collider(world, a, NULL));
    check(weft_world_collider_count(world) == 2 &&
              weft_world_set_collider(world, c, &far_away, NULL) == WEFT_RESULT_OK &&
              weft_world_set_collider(world, b, &far_away, NULL) == WEFT_RESULT_OK,
          "the other colliders keep their ids", 0.0);
    check(weft_world_remove_collider(world, a, NULL) == WEFT_RESULT_UNKNOWN_COLLIDER &&
              weft_world_set_collider(world, a, &far_away, NULL) == WEFT_RESULT_UNKNOWN_COLLIDER,
          "a removed collider's id is refused", (double)a);
    MUST(weft_world_add_collider(world, &def, &d, NULL));
    check(d != a && d != b && d != c, "a new collider gets a new id", (double)d);
    MUST(weft_world_clear_colliders(world, NULL));

    check(weft_world_user_data(world) == NULL, "no user data at first", 0.0);
    MUST(weft_world_set_user_data(world, &owner, NULL));
    check(weft_world_user_data(world) == &owner && *(int *)weft_world_user_data(world) == 42,
          "the world carries the engine's pointer", 0.0);
}

/* The sheet stretched by 10 % along u: every triangle's Green strain is [0.105, 0, 0]. */
static void strain_read_back(WeftWorld *world)
{
    static WeftVec3 stretched[VERTS];
    static float strain[TRIS][3];
    WeftErrorDetail d;
    float worst = 0.0f;
    int i;
    for (i = 0; i < VERTS; ++i) {
        stretched[i] = positions[i];
        stretched[i].x *= 1.1f;
    }
    MUST(weft_world_set_positions(world, stretched, VERTS, sizeof(WeftVec3), NULL));
    MUST(weft_world_get_triangle_strains(world, 0, TRIS, strain, sizeof strain[0], NULL));
    for (i = 0; i < TRIS; ++i) {
        float e = fabsf(strain[i][0] - 0.105f) + fabsf(strain[i][1]) + fabsf(strain[i][2]);
        if (e > worst)
            worst = e;
    }
    check(worst < 1e-5f, "a 10 % stretch along u reads back as E11 = 0.105", (double)strain[0][0]);
    check(weft_world_get_triangle_strains(world, TRIS - 1, 2, strain, sizeof strain[0], &d) ==
                  WEFT_RESULT_TRIANGLE_OUT_OF_RANGE &&
              d.needed == TRIS,
          "strains past the last triangle are refused", 0.0);
}

int main(int argc, char **argv)
{
    WeftErrorDetail detail;
    WeftBlob blob;
    WeftWorldDef def;
    WeftWorld *world = NULL;
    void *bytes, *memory = NULL;
    size_t blob_size = 0, memory_size = 0;

    if (argc < 2) {
        fprintf(stderr, "usage: %s CELLS.weft\n", argv[0]);
        return 2;
    }
    bytes = read_file(argv[1], &blob_size);
    if (bytes == NULL || weft_blob_parse(bytes, blob_size, &blob, &detail) != WEFT_RESULT_OK) {
        fprintf(stderr, "cannot read the blob %s\n", argv[1]);
        free(bytes);
        return 1;
    }
    make_sheet();
    def = weft_default_world_def();
    def.positions = positions;
    def.uvs = uvs;
    def.vertex_count = VERTS;
    def.indices = indices;
    def.triangle_count = TRIS;
    def.capacity.max_vertices = VERTS;
    def.capacity.max_triangles = TRIS;
    def.capacity.max_edges = 3 * TRIS;
    /* a free cloth: no gravity, no damping */
    def.settings.effects = WEFT_EFFECT_WARPING | WEFT_EFFECT_PINS;
    def.settings.tolerance = 1e-6f;
    def.settings.max_iterations = 1000;
    MUST(weft_world_memory_size(&def.capacity, &memory_size, NULL));
    memory = aligned_alloc(WEFT_WORLD_MEMORY_ALIGN, memory_size);
    if (memory != NULL) {
        /* (u, v) in the wrong units (1e-15 of the positions'): a cloth that could never step */
        static WeftVec2 tiny[VERTS];
        int i;
        for (i = 0; i < VERTS; ++i) {
            tiny[i].x = uvs[i].x * 1e-15f;
            tiny[i].y = uvs[i].y * 1e-15f;
        }
        def.uvs = tiny;
        check(weft_world_create(&def, &blob, memory, memory_size, &world, &detail) ==
                      WEFT_RESULT_MESH_STRAIN_OUT_OF_RANGE &&
                  detail.triangle == 0,
              "a cloth that could never step is refused", 0.0);
        def.uvs = uvs;
    }
    if (memory == NULL ||
        weft_world_create(&def, &blob, memory, memory_size, &world, &detail) != WEFT_RESULT_OK) {
        fprintf(stderr, "cannot create the world: %s\n", weft_result_string(detail.result));
        free(memory);
        free(bytes);
        return 1;
    }

    forces_impulses_masses(world);
    curtain_on_a_rail(world);
    ranges_and_teleport(world);
    collider_ids_and_user_data(world);
    strain_read_back(world);

    MUST(weft_world_destroy(world, NULL));
    free(memory);
    free(bytes);
    printf(failures == 0 ? "engine_api: ok\n" : "engine_api: %d FAILED\n", failures);
    return failures == 0 ? 0 : 1;
}
