/* VolPack (Lacroute's shear-warp, Debian libvolpack1-dev) on the same volume
 * and view as pvrsim's slice3d: a timing peer, not an image peer (VolPack
 * renders a luminance image with its own classification and no opacity
 * correction for the view; the transfer function's opacity is used per
 * voxel as VolPack's classifier table). Built and run by
 * bench/volpack/run.sh; not part of the cargo build.
 *
 *   volpack_bench RAW NX NY NZ DX DY DZ UX UY UZ SIZE FRAMES OPACITY_TABLE
 *
 * RAW: u8 voxels, x fastest. (DX,DY,DZ): view direction (world = voxel
 * axes, isotropic voxels), (UX,UY,UZ): up. OPACITY_TABLE: 256 numbers,
 * opacity per voxel value. Prints classification and per-frame times
 * (process CPU time and wall time, median over FRAMES).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <volpack.h>

typedef struct {
    unsigned short normal;
    unsigned char density;
} Voxel;

#define NORMAL_FIELD 0
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

static void normalize(double v[3]) {
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= n; v[1] /= n; v[2] /= n;
}

int main(int argc, char **argv) {
    if (argc != 14) {
        fprintf(stderr, "usage: %s RAW NX NY NZ DX DY DZ UX UY UZ SIZE FRAMES OPACITY_TABLE\n", argv[0]);
        return 2;
    }
    int nx = atoi(argv[2]), ny = atoi(argv[3]), nz = atoi(argv[4]);
    double f[3] = {atof(argv[5]), atof(argv[6]), atof(argv[7])};
    double up[3] = {atof(argv[8]), atof(argv[9]), atof(argv[10])};
    int size = atoi(argv[11]), frames = atoi(argv[12]);
    long n = (long)nx * ny * nz;
    unsigned char *raw = malloc(n);
    FILE *fp = fopen(argv[1], "rb");
    if (!fp || fread(raw, 1, n, fp) != (size_t)n) {
        fprintf(stderr, "%s: cannot read %ld voxels\n", argv[1], n);
        return 1;
    }
    fclose(fp);
    float opacity[256];
    FILE *ft = fopen(argv[13], "r");
    for (int i = 0; i < 256; i++) {
        if (!ft || fscanf(ft, "%f", &opacity[i]) != 1) {
            fprintf(stderr, "%s: need 256 opacities\n", argv[13]);
            return 1;
        }
    }
    fclose(ft);

    Voxel *vol = malloc(n * sizeof(Voxel));
    for (long i = 0; i < n; i++) {
        vol[i].normal = 0;
        vol[i].density = raw[i];
    }
    vpContext *vpc = vpCreateContext();
    Voxel dummy;
    check(vpc, vpSetVolumeSize(vpc, nx, ny, nz), "vpSetVolumeSize");
    check(vpc, vpSetVoxelSize(vpc, sizeof(Voxel), 2, 1, 1), "vpSetVoxelSize");
    check(vpc, vpSetVoxelField(vpc, NORMAL_FIELD, sizeof(dummy.normal),
                               vpFieldOffset(&dummy, normal), VP_NORM_MAX), "normal field");
    check(vpc, vpSetVoxelField(vpc, DENSITY_FIELD, sizeof(dummy.density),
                               vpFieldOffset(&dummy, density), 255), "density field");
    check(vpc, vpSetRawVoxels(vpc, vol, n * sizeof(Voxel), sizeof(Voxel),
                              nx * sizeof(Voxel), (long)nx * ny * sizeof(Voxel)), "vpSetRawVoxels");
    check(vpc, vpSetClassifierTable(vpc, 0, DENSITY_FIELD, opacity, sizeof(opacity)), "classifier");
    check(vpc, vpSetd(vpc, VP_MIN_VOXEL_OPACITY, 1e-4), "min opacity");
    check(vpc, vpSetd(vpc, VP_MAX_RAY_OPACITY, 0.99), "max ray opacity (ERT as ours)");
    /* Constant shading: every normal index gives luminance 255 (white). */
    static float shade[VP_NORM_MAX + 1];
    for (int i = 0; i <= VP_NORM_MAX; i++) shade[i] = 255.0f; /* VolPack colours are 0..255 */
    check(vpc, vpSetLookupShader(vpc, 1, 1, NORMAL_FIELD, shade, sizeof(shade), 0, NULL, 0),
          "shader");
    double t0 = now(CLOCK_MONOTONIC);
    check(vpc, vpClassifyVolume(vpc), "vpClassifyVolume");
    double tc = now(CLOCK_MONOTONIC) - t0;

    unsigned char *image = malloc((size_t)size * size);
    check(vpc, vpSetImage(vpc, image, size, size, size, VP_LUMINANCE), "vpSetImage");
    /* Model matrix: rows = camera right, up, -forward (VolPack looks along
     * -z in eye space), so the volume turns to our view direction. */
    normalize(f);
    double r[3] = {f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2],
                   f[0] * up[1] - f[1] * up[0]};
    normalize(r);
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2],
                   r[0] * f[1] - r[1] * f[0]};
    vpMatrix4 m;
    memset(m, 0, sizeof(m));
    for (int a = 0; a < 3; a++) {
        m[0][a] = r[a];
        m[1][a] = u[a];
        m[2][a] = -f[a];
    }
    m[3][3] = 1.0;
    check(vpc, vpCurrentMatrix(vpc, VP_MODEL), "model");
    check(vpc, vpSetMatrix(vpc, m), "vpSetMatrix");
    /* The unit-scaled volume's diagonal fits the window. */
    check(vpc, vpCurrentMatrix(vpc, VP_PROJECT), "project");
    check(vpc, vpWindow(vpc, VP_PARALLEL, -0.75, 0.75, -0.75, 0.75, -0.75, 0.75), "vpWindow");

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
    for (long i = 0; i < (long)size * size; i++) covered += image[i] > 0;
    printf("volpack %dx%dx%d at %d^2: classify %.1f ms; frame median cpu %.1f ms, wall %.1f ms "
           "(%d frames, 1 thread); %ld pixels non-zero\n",
           nx, ny, nz, size, tc * 1e3, cpu[frames / 2] * 1e3, wall[frames / 2] * 1e3, frames,
           covered);
    if (getenv("VOLPACK_PGM")) {
        FILE *o = fopen(getenv("VOLPACK_PGM"), "wb");
        fprintf(o, "P5\n%d %d\n255\n", size, size);
        fwrite(image, 1, (size_t)size * size, o);
        fclose(o);
    }
    return 0;
}
