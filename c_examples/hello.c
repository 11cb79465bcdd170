/*
 * hello.c: the smallest complete use of weft from C.
 *
 * Loads a cell blob, makes a 16 x 16-vertex cloth of cell 0, pins two corners, steps it for
 * 120 frames at 60 Hz and prints a few numbers. Every call's result is checked.
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
    WeftErrorDetail detail;
    WeftBlob blob;
    WeftCellInfo cell;
    WeftWorldDef def;
    WeftWorld *world = NULL;
    WeftStepStats stats;
    WeftResult r;
    void *bytes, *memory;
    size_t blob_size = 0, memory_size = 0;
    uint32_t corner_a = 0, corner_b = N - 1, centre = (N / 2) * N + N / 2;
    int i, j, t = 0, frame, status = 1;
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
    r = weft_blob_cell_info(&blob, 0, &cell);
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
    r = weft_world_memory_size(&def.capacity, &memory_size);
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
    if (failed(weft_world_set_pin(world, corner_a, positions[corner_a]), "weft_world_set_pin", NULL) ||
        failed(weft_world_set_pin(world, corner_b, positions[corner_b]), "weft_world_set_pin", NULL))
        goto done;
    for (frame = 1; frame <= FRAMES; ++frame) {
        r = weft_world_step(world, 1.0f / 60.0f, &stats);
        if (r != WEFT_RESULT_OK) {
            WeftErrorDetail d;
            if (weft_world_last_error_detail(world, &d) == WEFT_RESULT_OK)
                failed(r, "weft_world_step", &d);
            goto done;
        }
        /*
         * >>> LOCALIZATION GOES HERE <<<
         * Once localization exists, this is where the fine pattern is put back on the coarse
         * cloth for rendering (weft_world_localize into the render mesh). Nothing to call yet.
         */
    }

    /* 5. Read the result into our own array (tightly packed: stride = sizeof(WeftVec3)). */
    r = weft_world_get_positions(world, out, N * N, sizeof(WeftVec3));
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
    printf("hello: ok\n");
    status = 0;

done:
    /* 6. Destroy the world before freeing its memory and the blob it borrows. */
    if (world != NULL)
        weft_world_destroy(world);
    free(memory);
    free(bytes);
    return status;
}
