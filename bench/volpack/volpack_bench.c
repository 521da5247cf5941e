/* VolPack (Lacroute's shear-warp, Debian libvolpack1-dev) on a pvrsim scene:
 * a timing peer and an image peer. It renders RGBA with the scene's
 * orthographic camera, pixel-aligned with pvrsim's images, colours and
 * opacities from the scene's transfer function (bench/volpack/scene.py writes
 * the parameters). VolPack classifies each voxel (pre-classification: colour
 * and opacity per voxel, then resampled), with no opacity correction of its
 * own: scene.py corrects the table for this view's sample spacing (one
 * sample per slice of the principal axis). Built and run by
 * bench/volpack/run.sh; not part of the cargo build.
 *
 *   volpack_bench PARAMS
 *
 * PARAMS (whitespace-separated, written by scene.py):
 *   RAW NX NY NZ WIDTH HEIGHT FRAMES
 *   16 numbers: the model matrix (row-major; VolPack's object coordinates,
 *               voxel index i at (i - N/2) / max(N), to eye coordinates)
 *   LEFT RIGHT BOTTOM TOP NEAR FAR (vpWindow, VP_PARALLEL)
 *   256 opacities (per u8 voxel value, already corrected for the step)
 *   256 x 3 colours (0..255 scale, per u8 voxel value)
 *   OUT: raw RGBA8 output path, rows bottom to top as VolPack writes them
 *        ("-": none)
 *
 * Prints classification and per-frame times (process CPU and wall time,
 * median over FRAMES) on one line that run.sh and peer.sh parse.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <volpack.h>

/* VolPack's lookup shader indexes its colour table by a 2-byte shade field
 * (field 0), its classifier by the 1-byte density (field 1): both hold the
 * voxel's u8 value. */
typedef struct {
    unsigned short colour;
    unsigned char density;
} Voxel;

#define COLOUR_FIELD 0
#define DENSITY_FIELD 1

static double now(clockid_t c) {
    struct timespec t;
    clock_gettime(c, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void check(vpContext *vpc, vpResult r, const char *what) {
    if (r != VP_OK) {
        fprintf(stderr, "volpack: %s failed: %s\n", what, vpGetErrorString(vpGetError(vpc)));
        exit(1);
    }
}

static void need(int ok, const char *params, const char *what) {
    if (!ok) {
        fprintf(stderr, "%s: cannot read %s\n", params, what);
        exit(1);
    }
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s PARAMS (written by bench/volpack/scene.py)\n", argv[0]);
        return 2;
    }
    const char *pp = argv[1];
    FILE *pf = fopen(pp, "r");
    need(pf != NULL, pp, "the file");
    char raw_path[4096], out_path[4096];
    int nx, ny, nz, width, height, frames;
    need(fscanf(pf, "%4095s %d %d %d %d %d %d", raw_path, &nx, &ny, &nz, &width, &height,
                &frames) == 7,
         pp, "RAW NX NY NZ WIDTH HEIGHT FRAMES");
    need(nx > 1 && ny > 1 && nz > 1 && width > 0 && height > 0 && frames > 0, pp,
         "positive sizes");
    vpMatrix4 m;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) need(fscanf(pf, "%lf", &m[r][c]) == 1, pp, "the model matrix");
    double win[6];
    for (int i = 0; i < 6; i++) need(fscanf(pf, "%lf", &win[i]) == 1, pp, "the window");
    float opacity[256], colour[256 * 3];
    for (int i = 0; i < 256; i++) need(fscanf(pf, "%f", &opacity[i]) == 1, pp, "256 opacities");
    for (int i = 0; i < 256 * 3; i++) need(fscanf(pf, "%f", &colour[i]) == 1, pp, "256 x 3 colours");
    need(fscanf(pf, "%4095s", out_path) == 1, pp, "OUT");
    fclose(pf);

    long n = (long)nx * ny * nz;
    unsigned char *raw = malloc(n);
    FILE *fp = fopen(raw_path, "rb");
    if (!fp || fread(raw, 1, n, fp) != (size_t)n) {
        fprintf(stderr, "%s: cannot read %ld u8 voxels\n", raw_path, n);
        return 1;
    }
    fclose(fp);
    Voxel *vol = malloc(n * sizeof(Voxel));
    for (long i = 0; i < n; i++) {
        vol[i].colour = raw[i];
        vol[i].density = raw[i];
    }

    vpContext *vpc = vpCreateContext();
    Voxel dummy;
    check(vpc, vpSetVolumeSize(vpc, nx, ny, nz), "vpSetVolumeSize");
    check(vpc, vpSetVoxelSize(vpc, sizeof(Voxel), 2, 1, 1), "vpSetVoxelSize");
    check(vpc, vpSetVoxelField(vpc, COLOUR_FIELD, sizeof(dummy.colour),
                               vpFieldOffset(&dummy, colour), 255), "colour field");
    check(vpc, vpSetVoxelField(vpc, DENSITY_FIELD, sizeof(dummy.density),
                               vpFieldOffset(&dummy, density), 255), "density field");
    check(vpc, vpSetRawVoxels(vpc, vol, n * sizeof(Voxel), sizeof(Voxel),
                              nx * sizeof(Voxel), (long)nx * ny * sizeof(Voxel)), "vpSetRawVoxels");
    check(vpc, vpSetClassifierTable(vpc, 0, DENSITY_FIELD, opacity, sizeof(opacity)), "classifier");
    /* Voxels of (corrected) opacity below this are left out of the RLE. */
    check(vpc, vpSetd(vpc, VP_MIN_VOXEL_OPACITY, 1e-4), "min opacity");
    check(vpc, vpSetd(vpc, VP_MAX_RAY_OPACITY, 0.99), "max ray opacity (ERT as ours)");
    /* Colour per voxel value: the lookup shader indexed by the density. */
    check(vpc, vpSetLookupShader(vpc, 3, 1, COLOUR_FIELD, colour, sizeof(colour), 0, NULL, 0),
          "shader");
    double t0 = now(CLOCK_MONOTONIC);
    check(vpc, vpClassifyVolume(vpc), "vpClassifyVolume");
    double tc = now(CLOCK_MONOTONIC) - t0;

    unsigned char *image = malloc((size_t)width * height * 4);
    check(vpc, vpSetImage(vpc, image, width, height, width * 4, VP_RGBA), "vpSetImage");
    check(vpc, vpCurrentMatrix(vpc, VP_MODEL), "model");
    check(vpc, vpSetMatrix(vpc, m), "vpSetMatrix");
    check(vpc, vpCurrentMatrix(vpc, VP_PROJECT), "project");
    /* vpWindow multiplies into the projection, whose default is already a
     * window of [-0.5, 0.5]^3: start from the identity. */
    check(vpc, vpIdentityMatrix(vpc), "identity projection");
    check(vpc, vpWindow(vpc, VP_PARALLEL, win[0], win[1], win[2], win[3], win[4], win[5]),
          "vpWindow");

    double *cpu = malloc(frames * sizeof(double)), *wall = malloc(frames * sizeof(double));
    for (int k = 0; k < frames; k++) {
        double c0 = now(CLOCK_PROCESS_CPUTIME_ID), w0 = now(CLOCK_MONOTONIC);
        check(vpc, vpRenderClassifiedVolume(vpc), "vpRenderClassifiedVolume");
        cpu[k] = now(CLOCK_PROCESS_CPUTIME_ID) - c0;
        wall[k] = now(CLOCK_MONOTONIC) - w0;
    }
    qsort(cpu, frames, sizeof(double), cmp);
    qsort(wall, frames, sizeof(double), cmp);
    long covered = 0;
    for (long i = 0; i < (long)width * height; i++) covered += image[4 * i + 3] > 0;
    printf("volpack %dx%dx%d at %dx%d: classify %.1f ms; frame median cpu %.1f ms, wall %.1f ms "
           "(%d frames, 1 thread, RGBA); %ld pixels non-zero\n",
           nx, ny, nz, width, height, tc * 1e3, cpu[frames / 2] * 1e3, wall[frames / 2] * 1e3,
           frames, covered);
    if (strcmp(out_path, "-") != 0) {
        FILE *o = fopen(out_path, "wb");
        if (!o || fwrite(image, 4, (size_t)width * height, o) != (size_t)width * height) {
            fprintf(stderr, "%s: cannot write the image\n", out_path);
            return 1;
        }
        fclose(o);
    }
    return 0;
}
