/* Spheres by OSMesa (llvmpipe): one instanced quad per sphere, a sphere impostor in the fragment shader.
 *
 * The CPU projects every centre to pixels (render_camera_project) and a depth in [-1, 1], so the GPU side needs
 * no matrices and a test can predict where each sphere lands.  The fragment shader discards the quad outside the
 * disc, shades with a headlight (ambient 0.35 + diffuse 0.65 n.z, so the centre of each sphere has exactly the
 * colour map's colour) and writes the depth of the sphere's surface, so that intersecting spheres cut each
 * other correctly. */
#define GL_GLEXT_PROTOTYPES 1 /* declarations only: the functions are called through `gl`, below */
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>
#include <dlfcn.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "render/render.h"
#include "render/render_impl.h"

/* OSMesa is loaded when the first renderer is made, not linked: linking it loads llvmpipe (LLVM, Z3 and more)
 * into every spraycoat process, and their relocations cost ~0.04 s of CPU and ~0.15 s of wall time before main
 * in every command, though only rendering needs them (BENCHMARKS.md's history in git).  libOSMesa
 * exports the GL entry points it implements; each is looked up once, with the type of its declaration. */
#define OSMESA_LIBRARY "libOSMesa.so.8"
/* One function a line: clang-format reflows this list differently on every pass. */
/* clang-format off */
#define GL_FUNCTIONS(X) \
    X(OSMesaCreateContextAttribs) \
    X(OSMesaMakeCurrent) \
    X(OSMesaPixelStore) \
    X(OSMesaDestroyContext) \
    X(glCreateShader) \
    X(glShaderSource) \
    X(glCompileShader) \
    X(glGetShaderiv) \
    X(glGetShaderInfoLog) \
    X(glDeleteShader) \
    X(glCreateProgram) \
    X(glAttachShader) \
    X(glLinkProgram) \
    X(glGetProgramiv) \
    X(glGetUniformLocation) \
    X(glDeleteProgram) \
    X(glUseProgram) \
    X(glUniform1f) \
    X(glUniform2f) \
    X(glGenVertexArrays) \
    X(glBindVertexArray) \
    X(glDeleteVertexArrays) \
    X(glGenBuffers) \
    X(glBindBuffer) \
    X(glBufferData) \
    X(glDeleteBuffers) \
    X(glVertexAttribPointer) \
    X(glVertexAttribDivisor) \
    X(glEnableVertexAttribArray) \
    X(glDrawArraysInstanced) \
    X(glViewport) \
    X(glClearColor) \
    X(glClearDepth) \
    X(glClear) \
    X(glEnable) \
    X(glDepthFunc) \
    X(glFinish) \
    X(glGetError)
/* clang-format on */
#define GL_DECLARE(name) __typeof__(name) *name;
static struct {
    GL_FUNCTIONS(GL_DECLARE)
} gl;

/* Load OSMesa and look up every function of GL_FUNCTIONS, once per process. */
static int gl_load(void)
{
    static void *library;
    if (library)
        return SC_OK;
    void *handle = dlopen(OSMESA_LIBRARY, RTLD_NOW | RTLD_LOCAL);
    if (!handle)
        SC_FAIL(SC_EIO, "render: cannot load %s (%s); install Mesa's OSMesa (Debian: libosmesa6)", OSMESA_LIBRARY,
                dlerror());
    const char *missing = NULL;
#define GL_LOOK_UP(name)                                                                                               \
    gl.name = (__typeof__(name) *)dlsym(handle, #name);                                                                \
    missing = !gl.name && !missing ? #name : missing;
    GL_FUNCTIONS(GL_LOOK_UP)
#undef GL_LOOK_UP
    if (missing) {
        dlclose(handle);
        SC_FAIL(SC_EIO, "render: %s has no %s", OSMESA_LIBRARY, missing);
    }
    library = handle;
    return SC_OK;
}

struct render_renderer {
    OSMesaContext context;
    int width, height;
    unsigned char *buffer; /* BGRA, row 0 at the top */
    GLuint program, vao, corner_buffer, sphere_buffer, colour_buffer;
    GLint viewport_location, depth_location;
    struct render_image image;
};

static const char vertex_source[] =
    "#version 330 core\n"
    "layout(location = 0) in vec2 corner;\n"
    "layout(location = 1) in vec4 sphere;   /* pixel x, pixel y (from the top), depth in [-1, 1], radius px */\n"
    "layout(location = 2) in vec4 colour;\n"
    "uniform vec2 viewport;\n"
    "uniform float depth_per_pixel;\n"
    "out vec2 local;\n"
    "flat out vec3 base;\n"
    "flat out float centre_depth;\n"
    "flat out float depth_radius;\n"
    "void main() {\n"
    "    vec2 pixel = sphere.xy + corner * sphere.w;\n"
    "    gl_Position = vec4(2.0 * pixel.x / viewport.x - 1.0, 1.0 - 2.0 * pixel.y / viewport.y, sphere.z, 1.0);\n"
    "    local = corner;\n"
    "    base = colour.rgb;\n"
    "    centre_depth = sphere.z;\n"
    "    depth_radius = sphere.w * depth_per_pixel;\n"
    "}\n";

static const char fragment_source[] = "#version 330 core\n"
                                      "in vec2 local;\n"
                                      "flat in vec3 base;\n"
                                      "flat in float centre_depth;\n"
                                      "flat in float depth_radius;\n"
                                      "out vec4 frag;\n"
                                      "void main() {\n"
                                      "    float d2 = dot(local, local);\n"
                                      "    if (d2 > 1.0) discard;\n"
                                      "    float nz = sqrt(1.0 - d2);\n"
                                      "    frag = vec4(base * (0.35 + 0.65 * nz), 1.0);\n"
                                      "    gl_FragDepth = 0.5 * (centre_depth - depth_radius * nz) + 0.5;\n"
                                      "}\n";

static int compile_shader(GLenum type, const char *source, GLuint *out)
{
    GLuint shader = gl.glCreateShader(type);
    gl.glShaderSource(shader, 1, &source, NULL);
    gl.glCompileShader(shader);
    GLint ok = 0;
    gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[1024] = "";
        gl.glGetShaderInfoLog(shader, sizeof log, NULL, log);
        gl.glDeleteShader(shader);
        SC_FAIL(SC_EIO, "render: OSMesa cannot compile a shader: %s", log);
    }
    *out = shader;
    return SC_OK;
}

static int build_program(struct render_renderer *r)
{
    GLuint vs, fs;
    SC_TRY(compile_shader(GL_VERTEX_SHADER, vertex_source, &vs));
    int status = compile_shader(GL_FRAGMENT_SHADER, fragment_source, &fs);
    if (status != SC_OK)
        gl.glDeleteShader(vs);
    SC_TRY(status);
    r->program = gl.glCreateProgram();
    gl.glAttachShader(r->program, vs);
    gl.glAttachShader(r->program, fs);
    gl.glLinkProgram(r->program);
    gl.glDeleteShader(vs);
    gl.glDeleteShader(fs);
    GLint ok = 0;
    gl.glGetProgramiv(r->program, GL_LINK_STATUS, &ok);
    if (!ok)
        SC_FAIL(SC_EIO, "render: OSMesa cannot link the sphere shader");
    r->viewport_location = gl.glGetUniformLocation(r->program, "viewport");
    r->depth_location = gl.glGetUniformLocation(r->program, "depth_per_pixel");
    return SC_OK;
}

/* The quad's corners, and per-instance attributes: sphere (4 floats) and colour (4 normalised bytes). */
static void build_vertex_arrays(struct render_renderer *r)
{
    static const float corners[] = {-1, -1, 1, -1, -1, 1, 1, 1};
    gl.glGenVertexArrays(1, &r->vao);
    gl.glBindVertexArray(r->vao);
    gl.glGenBuffers(1, &r->corner_buffer);
    gl.glBindBuffer(GL_ARRAY_BUFFER, r->corner_buffer);
    gl.glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
    gl.glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, NULL);
    gl.glEnableVertexAttribArray(0);
    gl.glGenBuffers(1, &r->sphere_buffer);
    gl.glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
    gl.glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 0, NULL);
    gl.glVertexAttribDivisor(1, 1);
    gl.glEnableVertexAttribArray(1);
    gl.glGenBuffers(1, &r->colour_buffer);
    gl.glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
    gl.glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, NULL);
    gl.glVertexAttribDivisor(2, 1);
    gl.glEnableVertexAttribArray(2);
}

int render_renderer_create(int width, int height, struct render_renderer **out)
{
    if (width < 16 || height < 16 || width > 16384 || height > 16384)
        SC_FAIL(SC_EINPUT, "render: image size %d x %d px; allowed: 16 to 16384 px each way", width, height);
    SC_TRY(gl_load());
    struct render_renderer *r = calloc(1, sizeof *r);
    unsigned char *buffer = malloc((size_t)width * (size_t)height * 4);
    if (!r || !buffer) {
        free(r);
        free(buffer);
        SC_FAIL_OOM(sizeof *r + (size_t)width * (size_t)height * 4, "the image");
    }
    r->buffer = buffer, r->width = width, r->height = height;
    static const int attributes[] = {OSMESA_FORMAT,
                                     OSMESA_BGRA,
                                     OSMESA_DEPTH_BITS,
                                     24,
                                     OSMESA_STENCIL_BITS,
                                     0,
                                     OSMESA_PROFILE,
                                     OSMESA_CORE_PROFILE,
                                     OSMESA_CONTEXT_MAJOR_VERSION,
                                     3,
                                     OSMESA_CONTEXT_MINOR_VERSION,
                                     3,
                                     0};
    r->context = gl.OSMesaCreateContextAttribs(attributes, NULL);
    if (!r->context || !gl.OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, width, height)) {
        render_renderer_destroy(r);
        SC_FAIL(SC_EIO, "render: cannot create an OSMesa GL 3.3 core context (is Mesa's libOSMesa installed?)");
    }
    gl.OSMesaPixelStore(OSMESA_Y_UP, 0); /* row 0 of the buffer is the top row, as Cairo and PNG want it */
    int status = build_program(r);
    if (status != SC_OK)
        render_renderer_destroy(r);
    SC_TRY(status);
    build_vertex_arrays(r);
    r->image = (struct render_image){width, height, width * 4, (uint32_t *)r->buffer};
    *out = r;
    return SC_OK;
}

void render_renderer_destroy(struct render_renderer *r)
{
    if (!r)
        return;
    if (r->context) {
        gl.OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, r->width, r->height);
        if (r->program) {
            gl.glDeleteBuffers(1, &r->corner_buffer);
            gl.glDeleteBuffers(1, &r->sphere_buffer);
            gl.glDeleteBuffers(1, &r->colour_buffer);
            gl.glDeleteVertexArrays(1, &r->vao);
            gl.glDeleteProgram(r->program);
        }
        gl.OSMesaDestroyContext(r->context);
    }
    free(r->buffer);
    free(r);
}

/* Sphere i as pixels and depth, and its colour, for the visible ones; returns how many. */
static size_t project_spheres(const struct render_spheres *s, const struct render_scene *scene,
                              const struct render_camera *cam, float *spheres, unsigned char *colours)
{
    size_t n = 0;
    double range = scene->vmax - scene->vmin;
    for (size_t i = 0; i < s->count; i++) {
        const double *x = s->x + 3 * i;
        if (!render_view_shows(scene, x))
            continue;
        double px, py, rgb[3];
        render_camera_project(cam, x, &px, &py);
        double depth = 0;
        for (int k = 0; k < 3; k++)
            depth += (x[k] - cam->center[k]) * cam->toward[k];
        double radius = (s->radius ? s->radius[i] : s->common_radius) * cam->pixels_per_metre;
        spheres[4 * n] = (float)px;
        spheres[4 * n + 1] = (float)py;
        spheres[4 * n + 2] = (float)(-depth / cam->depth_half); /* nearer the viewer: smaller depth */
        spheres[4 * n + 3] = (float)fmax(radius, scene->min_pixel_radius);
        double v = s->value[i];
        if (isfinite(v)) {
            render_viridis(range > 0 ? (v - scene->vmin) / range : 0.5, rgb);
        } else {
            rgb[0] = rgb[1] = rgb[2] = 0.6; /* no value: grey */
        }
        for (int k = 0; k < 3; k++)
            colours[4 * n + (size_t)k] = (unsigned char)lround(255 * rgb[k]);
        colours[4 * n + 3] = 255;
        n++;
    }
    return n;
}

static void draw_instances(struct render_renderer *r, const float *spheres, const unsigned char *colours, size_t n,
                           const struct render_camera *cam)
{
    gl.glViewport(0, 0, r->width, r->height);
    gl.glClearColor(1, 1, 1, 1);
    gl.glClearDepth(1);
    gl.glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl.glEnable(GL_DEPTH_TEST);
    gl.glDepthFunc(GL_LESS);
    gl.glUseProgram(r->program);
    gl.glUniform2f(r->viewport_location, (float)r->width, (float)r->height);
    gl.glUniform1f(r->depth_location, (float)(1.0 / (cam->pixels_per_metre * cam->depth_half)));
    gl.glBindVertexArray(r->vao);
    gl.glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
    gl.glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(n * 4 * sizeof *spheres), spheres, GL_STREAM_DRAW);
    gl.glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
    gl.glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(n * 4), colours, GL_STREAM_DRAW);
    /* in slices, so that one call never holds more vertices than llvmpipe's 32-bit counters like */
    const size_t slice = 1u << 20;
    for (size_t first = 0; first < n; first += slice) {
        size_t count = n - first < slice ? n - first : slice;
        gl.glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
        gl.glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 0, (const void *)(first * 4 * sizeof *spheres));
        gl.glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
        gl.glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, (const void *)(first * 4));
        gl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, (GLsizei)count);
    }
    gl.glFinish();
}

int render_spheres_draw(struct render_renderer *r, const struct render_spheres *s, const struct render_scene *scene,
                        struct render_camera *cam_out, const struct render_image **image)
{
    if (scene->width != r->width || scene->height != r->height)
        SC_FAIL(SC_EINPUT, "render: scene of %d x %d px on a renderer of %d x %d px", scene->width, scene->height,
                r->width, r->height);
    struct render_camera cam;
    SC_TRY(render_camera_frame(s, scene, &cam));
    float *spheres = malloc((4 * s->count + 4) * sizeof *spheres);
    unsigned char *colours = malloc(4 * s->count + 4);
    if (!spheres || !colours) {
        free(spheres);
        free(colours);
        SC_FAIL_OOM((4 * s->count + 4) * (sizeof *spheres + 1), "the spheres of a picture");
    }
    size_t n = project_spheres(s, scene, &cam, spheres, colours);
    if (!gl.OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, r->width, r->height)) {
        free(spheres);
        free(colours);
        SC_FAIL(SC_EIO, "render: cannot make the OSMesa context current");
    }
    draw_instances(r, spheres, colours, n, &cam);
    free(spheres);
    free(colours);
    GLenum error = gl.glGetError();
    if (error != GL_NO_ERROR)
        SC_FAIL(SC_EIO, "render: OpenGL error 0x%x while drawing %zu spheres", (unsigned)error, n);
    SC_TRY(render_overlay_scene(&r->image, scene, &cam));
    if (cam_out)
        *cam_out = cam;
    *image = &r->image;
    return SC_OK;
}
