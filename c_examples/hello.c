/*
 * hello.c: the smallest complete use of weft from C.
 *
 * Loads a cell blob, makes a 16 x 16-vertex cloth of cell 0, pins two corners, steps it for
 * 120 frames at 60 Hz, then localizes it: the cell's own micro mesh, tiled over the cloth, is
 * bound to it and put back on it, and a few numbers of both meshes are printed. Every call's
 * result is checked.
 *
 *   cc -std=c11 -I include c_examples/hello.c target/ship/libweft.a -o hello
 *   ./hello cells.weft
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "weft.h"

#define N 16        /* vertices along each side */
#define SIDE 0.5f   /* metres */
#define FRAMES 120
#define MATERIALS 8 /* pattern materials counted in the strain summary */

/* Prints a failed call with its detail and returns nonzero. */
static int failed(WeftResult r, const char *call, const WeftErrorDetail *d)
{
    if (r == WEFT_RESULT_OK)
        return 0;
    fprintf(stderr, "%s: %s (result %u)", call, weft_result_string(r), (unsigned)r);
    if (d != NULL) {
        if (d->triangle != WEFT_NONE)
            fprintf(stderr, ", triangle %u", (unsigned)d->triangle);
        if (d->vertex != WEFT_NONE)
            fprintf(stderr, ", vertex %u", (unsigned)d->vertex);
        if (d->needed != WEFT_NONE)
            fprintf(stderr, ", needed %u", (unsigned)d->needed);
        if (d->capacity != WEFT_NONE)
            fprintf(stderr, ", capacity %u", (unsigned)d->capacity);
        if (d->what[0] != '\0')
            fprintf(stderr, ", %s", d->what);
    }
    fprintf(stderr, "\n");
    return 1;
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

int main(int argc, char **argv)
{
    static WeftVec3 positions[N * N];
    static WeftVec2 uvs[N * N];
    static uint32_t indices[6 * (N - 1) * (N - 1)];
    static WeftVec3 out[N * N];
    WeftVec2 *fine_uvs = NULL;      /* the fine render mesh: (u, v) ... */
    uint32_t *fine_indices = NULL;  /* ... triangles, their pattern material ... */
    uint32_t *fine_materials = NULL;
    WeftVec3 *fine_positions = NULL; /* ... and where localization puts it */
    void *bindings = NULL, *frames = NULL;
    size_t bindings_size = 0, frames_size = 0;
    uint32_t fine_count = 0, fine_triangles = 0;
    WeftLocalizeOutput output;
    float box[2][2][3]; /* [coarse, fine][min, max][x, y, z] */
    float dx, dy, dz, gap_mm, worst_mm = 0.0f;
    double strain[MATERIALS + 1] = {0.0}, edges[MATERIALS + 1] = {0.0};
    double fine_strain = 0.0, fine_edges = 0.0;
    WeftErrorDetail detail;
    WeftBlob blob;
    WeftCellInfo cell;
    WeftWorldDef def;
    WeftWorld *world = NULL;
    WeftStepStats stats;
    WeftResult r;
    void *bytes, *memory = NULL;
    size_t blob_size = 0, memory_size = 0;
    uint32_t corner_a = 0, corner_b = N - 1, centre = (N / 2) * N + N / 2;
    int i, j, k, t = 0, frame, status = 1;
    float lowest = 1.0f;

    if (argc < 2) {
        fprintf(stderr, "usage: %s CELLS.weft\n", argv[0]);
        return 2;
    }
    if (weft_version() != WEFT_VERSION) {
        fprintf(stderr, "weft.h does not match the library\n");
        return 1;
    }

    /* 1. The cells: parsed in place, borrowed (not copied) until the world is destroyed. */
    bytes = read_file(argv[1], &blob_size);
    if (bytes == NULL) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 1;
    }
    r = weft_blob_parse(bytes, blob_size, &blob, &detail);
    if (failed(r, "weft_blob_parse", &detail)) {
        free(bytes);
        return 1;
    }
    r = weft_blob_cell_info(&blob, 0, &cell, NULL);
    if (failed(r, "weft_blob_cell_info", NULL)) {
        free(bytes);
        return 1;
    }
    printf("weft %u.%u.%u, blob version %u with %u cell(s)\n", (unsigned)(weft_version() >> 16),
           (unsigned)((weft_version() >> 8) & 0xff), (unsigned)(weft_version() & 0xff),
           (unsigned)blob.version, (unsigned)blob.cell_count);
    printf("cell 0: %s, %.4g m wide, C11 = %.1f N/m, C22 = %.1f N/m\n", cell.name, cell.width,
           cell.stiffness[0][0], cell.stiffness[1][1]);

    /* 2. The cloth: a flat square 1 m up; its (u, v) are its flat layout in metres. */
    for (j = 0; j < N; ++j) {
        for (i = 0; i < N; ++i) {
            float u = SIDE * (float)i / (N - 1), v = SIDE * (float)j / (N - 1);
            positions[j * N + i].x = u;
            positions[j * N + i].y = v;
            positions[j * N + i].z = 1.0f;
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
    def = weft_default_world_def();
    def.positions = positions;
    def.uvs = uvs;
    def.vertex_count = N * N;
    def.indices = indices;
    def.triangle_count = (uint32_t)(t / 3);
    def.material = 0; /* every triangle is cell 0 */
    def.settings.substeps = 2;

    /* 3. The world lives in memory we own. */
    r = weft_world_memory_size(&def.capacity, &memory_size, NULL);
    if (failed(r, "weft_world_memory_size", NULL)) {
        free(bytes);
        return 1;
    }
    memory = aligned_alloc(weft_world_memory_align(), memory_size);
    if (memory == NULL) {
        free(bytes);
        return 1;
    }
    r = weft_world_create(&def, &blob, memory, memory_size, &world, &detail);
    if (failed(r, "weft_world_create", &detail))
        goto done;
    printf("world: %u vertices, %u triangles, %zu bytes\n",
           (unsigned)weft_world_vertex_count(world), (unsigned)weft_world_triangle_count(world),
           memory_size);

    /* 4. Pin two corners where they are, and let the rest fall. */
    if (failed(weft_world_set_pin(world, corner_a, positions[corner_a], NULL), "weft_world_set_pin", NULL) ||
        failed(weft_world_set_pin(world, corner_b, positions[corner_b], NULL), "weft_world_set_pin", NULL))
        goto done;
    for (frame = 1; frame <= FRAMES; ++frame) {
        r = weft_world_step(world, 1.0f / 60.0f, &stats, &detail);
        if (failed(r, "weft_world_step", &detail))
            goto done;
        /* An engine localizes here, every frame it draws (step 6 below, after the loop). */
    }

    /* 5. Read the result into our own array (tightly packed: stride = sizeof(WeftVec3)). */
    r = weft_world_get_positions(world, out, N * N, sizeof(WeftVec3), NULL);
    if (failed(r, "weft_world_get_positions", NULL))
        goto done;
    for (i = 0; i < N * N; ++i) {
        if (!(out[i].x == out[i].x && out[i].z == out[i].z)) {
            fprintf(stderr, "vertex %d is NaN\n", i);
            goto done;
        }
        if (out[i].z < lowest)
            lowest = out[i].z;
    }
    printf("frame %d: %u solver iterations, residual %.2g, %s\n", FRAMES,
           (unsigned)stats.iterations, (double)stats.residual,
           stats.converged ? "converged" : "not converged");
    printf("pinned corner: (%.3f, %.3f, %.3f)\n", (double)out[corner_b].x, (double)out[corner_b].y,
           (double)out[corner_b].z);
    printf("centre: (%.3f, %.3f, %.3f), lowest z = %.3f m\n", (double)out[centre].x,
           (double)out[centre].y, (double)out[centre].z, (double)lowest);
    if (out[corner_b].z < 1.0f - 1e-5f || out[corner_b].z > 1.0f + 1e-5f || !(lowest < 0.9f)) {
        fprintf(stderr, "the cloth did not hang from its pins\n");
        goto done;
    }

    /*
     * 6. Localize. The render mesh here is the cell's own micro mesh tiled over the cloth's
     * (u, v) (any mesh with (u, v) in the cloth's layout works). Binding is once per mesh;
     * prepare + localize is what an engine does every frame it draws.
     */
    r = weft_tiled_mesh_counts(world, 0, &fine_count, &fine_triangles, &detail);
    if (failed(r, "weft_tiled_mesh_counts", &detail))
        goto done;
    fine_uvs = malloc(fine_count * sizeof *fine_uvs);
    fine_indices = malloc(3 * (size_t)fine_triangles * sizeof *fine_indices);
    fine_materials = malloc(fine_triangles * sizeof *fine_materials);
    fine_positions = malloc(fine_count * sizeof *fine_positions);
    if (fine_uvs == NULL || fine_indices == NULL || fine_materials == NULL ||
        fine_positions == NULL)
        goto done;
    r = weft_tiled_mesh(world, 0, fine_uvs, fine_count, fine_indices, fine_triangles,
                        fine_materials, &detail);
    if (failed(r, "weft_tiled_mesh", &detail))
        goto done;
    r = weft_bind_memory_size(fine_count, &bindings_size, NULL);
    if (failed(r, "weft_bind_memory_size", NULL) || (bindings = malloc(bindings_size)) == NULL)
        goto done;
    r = weft_bind(world, fine_uvs, fine_count, sizeof(WeftVec2), bindings, bindings_size,
                  &detail);
    if (failed(r, "weft_bind", &detail))
        goto done;
    printf("fine mesh: %u vertices, %u triangles (cell 0 tiled at %.3g mm), %zu bytes of "
           "bindings\n",
           (unsigned)fine_count, (unsigned)fine_triangles,
           1000.0 * cell.width / (cell.cols * cell.refine), bindings_size);

    r = weft_localize_frames_size(world, &frames_size, NULL);
    if (failed(r, "weft_localize_frames_size", NULL) ||
        (frames = aligned_alloc(WEFT_LOCALIZE_FRAMES_ALIGN, frames_size)) == NULL)
        goto done;
    r = weft_localize_prepare(world, WEFT_STRAIN_COROTATED, frames, frames_size, &detail);
    if (failed(r, "weft_localize_prepare", &detail))
        goto done;
    output = weft_default_localize_output();
    output.positions = fine_positions;
    output.position_stride = sizeof(WeftVec3);
    r = weft_localize(world, frames, bindings, bindings_size, 0, fine_count, &output, &detail);
    if (failed(r, "weft_localize", &detail))
        goto done;

    /* The fine mesh covers the coarse cloth: same extent, up to the micro displacement. */
    for (k = 0; k < 3; ++k) {
        box[0][0][k] = box[1][0][k] = 1e30f;
        box[0][1][k] = box[1][1][k] = -1e30f;
    }
    for (i = 0; i < N * N + (int)fine_count; ++i) {
        const WeftVec3 *p = i < N * N ? &out[i] : &fine_positions[i - N * N];
        float c[3];
        int m = i < N * N ? 0 : 1;
        c[0] = p->x;
        c[1] = p->y;
        c[2] = p->z;
        for (k = 0; k < 3; ++k) {
            if (!(c[k] == c[k])) {
                fprintf(stderr, "a localized vertex is NaN\n");
                goto done;
            }
            if (c[k] < box[m][0][k])
                box[m][0][k] = c[k];
            if (c[k] > box[m][1][k])
                box[m][1][k] = c[k];
        }
    }
    for (i = 0; i < 2; ++i)
        printf("%s extent: x [%.4f, %.4f] y [%.4f, %.4f] z [%.4f, %.4f]\n",
               i == 0 ? "coarse" : "fine  ", (double)box[i][0][0], (double)box[i][1][0],
               (double)box[i][0][1], (double)box[i][1][1], (double)box[i][0][2],
               (double)box[i][1][2]);
    for (i = 0; i < 2; ++i)
        for (k = 0; k < 3; ++k) {
            gap_mm = 1000.0f * (box[1][i][k] - box[0][i][k]);
            if (gap_mm < 0.0f)
                gap_mm = -gap_mm;
            if (gap_mm > worst_mm)
                worst_mm = gap_mm;
        }
    printf("extents differ by %.3f mm at most\n", (double)worst_mm);
    if (!(worst_mm < 1.0f)) {
        fprintf(stderr, "the fine mesh does not cover the coarse cloth\n");
        goto done;
    }

    /*
     * What localization is for: the fine pattern's own deformation. The cloth hangs along v,
     * across the stripes; the mean Green strain (|dx|^2 / |dv|^2 - 1) / 2 of the edges along v
     * is measured on the coarse mesh and per pattern material on the fine one. The soft layers
     * take most of the stretch, and the layers average to the coarse strain.
     */
    for (i = 0; i < 2 * (N - 1) * (N - 1) + (int)fine_triangles; ++i) {
        int coarse = i < 2 * (N - 1) * (N - 1);
        const uint32_t *tri = coarse ? &indices[3 * i] : &fine_indices[3 * (i - t / 3)];
        const WeftVec2 *uv = coarse ? uvs : fine_uvs;
        const WeftVec3 *x = coarse ? out : fine_positions;
        int slot = coarse ? MATERIALS : (int)fine_materials[i - t / 3];
        if (!coarse && slot >= MATERIALS)
            continue;
        for (k = 0; k < 3; ++k) {
            uint32_t a = tri[k], b = tri[(k + 1) % 3];
            float du = uv[b].x - uv[a].x, dv = uv[b].y - uv[a].y;
            if (du > 1e-7f || du < -1e-7f || dv == 0.0f)
                continue; /* not an edge along v */
            dx = x[b].x - x[a].x;
            dy = x[b].y - x[a].y;
            dz = x[b].z - x[a].z;
            strain[slot] += 0.5 * ((double)(dx * dx + dy * dy + dz * dz) / (double)(dv * dv) - 1.0);
            edges[slot] += 1.0;
        }
    }
    for (k = 0; k < MATERIALS; ++k) {
        fine_strain += strain[k];
        fine_edges += edges[k];
    }
    printf("strain along v (Green, mean over edges along v): coarse %.4f %%, fine %.4f %% =",
           100.0 * strain[MATERIALS] / edges[MATERIALS], 100.0 * fine_strain / fine_edges);
    for (k = 0; k < MATERIALS; ++k)
        if (edges[k] > 0.0)
            printf(" material %d: %.4f %%", k, 100.0 * strain[k] / edges[k]);
    printf("\n");
    printf("hello: ok\n");
    status = 0;

done:
    /* 7. Destroy the world before freeing its memory and the blob it borrows. */
    if (world != NULL)
        weft_world_destroy(world, NULL);
    free(frames);
    free(bindings);
    free(fine_positions);
    free(fine_materials);
    free(fine_indices);
    free(fine_uvs);
    free(memory);
    free(bytes);
    return status;
}
