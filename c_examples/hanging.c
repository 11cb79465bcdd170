/* A cloth hanging from two corners, in full: the README's example (tests/c_examples.rs). */
#include <stdio.h>
#include <stdlib.h>
#include "weft.h"
#define N 16 /* vertices along each side */

int main(int argc, char **argv)
{
    static WeftVec3 positions[N * N];
    static WeftVec2 uvs[N * N];
    static uint32_t indices[6 * (N - 1) * (N - 1)];
    WeftErrorDetail detail;
    WeftBlob blob; WeftWorld *world = NULL;
    FILE *file = argc > 1 ? fopen(argv[1], "rb") : NULL; /* cells from weft-cell */
    if (file == NULL || fseek(file, 0, SEEK_END) != 0) return 2;
    size_t size = (size_t)ftell(file), memory_size = 0;
    void *bytes = malloc(size), *memory = NULL;
    rewind(file);
    if (fread(bytes, 1, size, file) != size || fclose(file) != 0 ||
        weft_blob_parse(bytes, size, &blob, &detail) != WEFT_RESULT_OK) return 1;
    WeftWorldDef def = weft_default_world_def(); /* a 0.5 m square of cell 0, flat at z = 0 */
    weft_grid(N, N, 0.5f, 0.5f, positions, uvs, indices, NULL);
    def.positions = positions, def.uvs = uvs, def.indices = indices;
    def.vertex_count = N * N, def.triangle_count = 2 * (N - 1) * (N - 1);
    weft_world_memory_size(&def.capacity, &memory_size, NULL);
    memory = aligned_alloc(WEFT_WORLD_MEMORY_ALIGN, memory_size); /* the world lives here */
    if (weft_world_create(&def, &blob, memory, memory_size, &world, &detail) != WEFT_RESULT_OK)
        return printf("create: %s\n", weft_result_string(detail.result)), 1;
    weft_world_set_pin(world, N * (N - 1), positions[N * (N - 1)], NULL); /* top corners */
    weft_world_set_pin(world, N * N - 1, positions[N * N - 1], NULL);
    for (int frame = 0; frame < 120; ++frame) /* 2 s at 60 Hz */
        if (weft_world_step(world, 1.0f / 60.0f, NULL, &detail) != WEFT_RESULT_OK)
            return printf("step: %s\n", weft_result_string(detail.result)), 1;
    weft_world_get_positions(world, positions, N * N, sizeof positions[0], NULL);
    printf("hanging: the bottom corners are at z = %.3f and %.3f m\n", positions[0].z,
           positions[N - 1].z);
    weft_world_destroy(world, NULL);
    free(memory), free(bytes);
    return 0;
}
