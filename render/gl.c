/* Spheres by OSMesa (llvmpipe): one instanced quad per sphere, a sphere impostor in the fragment shader.
 *
 * The CPU projects every centre to pixels (render_camera_project) and a depth in [-1, 1], so the GPU side needs
 * no matrices and a test can predict where each sphere lands.  The fragment shader discards the quad outside the
 * disc, shades with a headlight (ambient 0.35 + diffuse 0.65 n.z, so the centre of each sphere has exactly the
 * colour map's colour) and writes the depth of the sphere's surface, so that intersecting spheres cut each
 * other correctly. */
#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "render/render.h"
#include "render/render_impl.h"

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

static const char fragment_source[] =
    "#version 330 core\n"
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
    GLuint shader = glCreateShader(type);
    glShaderSource(shader, 1, &source, NULL);
    glCompileShader(shader);
    GLint ok = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[1024] = "";
        glGetShaderInfoLog(shader, sizeof log, NULL, log);
        glDeleteShader(shader);
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
    if (status != SC_OK) {
        glDeleteShader(vs);
        return status;
    }
    r->program = glCreateProgram();
    glAttachShader(r->program, vs);
    glAttachShader(r->program, fs);
    glLinkProgram(r->program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(r->program, GL_LINK_STATUS, &ok);
    if (!ok)
        SC_FAIL(SC_EIO, "render: OSMesa cannot link the sphere shader");
    r->viewport_location = glGetUniformLocation(r->program, "viewport");
    r->depth_location = glGetUniformLocation(r->program, "depth_per_pixel");
    return SC_OK;
}

/* The quad's corners, and per-instance attributes: sphere (4 floats) and colour (4 normalised bytes). */
static void build_vertex_arrays(struct render_renderer *r)
{
    static const float corners[] = {-1, -1, 1, -1, -1, 1, 1, 1};
    glGenVertexArrays(1, &r->vao);
    glBindVertexArray(r->vao);
    glGenBuffers(1, &r->corner_buffer);
    glBindBuffer(GL_ARRAY_BUFFER, r->corner_buffer);
    glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
    glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, NULL);
    glEnableVertexAttribArray(0);
    glGenBuffers(1, &r->sphere_buffer);
    glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
    glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 0, NULL);
    glVertexAttribDivisor(1, 1);
    glEnableVertexAttribArray(1);
    glGenBuffers(1, &r->colour_buffer);
    glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
    glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, NULL);
    glVertexAttribDivisor(2, 1);
    glEnableVertexAttribArray(2);
}

int render_renderer_create(int width, int height, struct render_renderer **out)
{
    if (width < 16 || height < 16 || width > 16384 || height > 16384)
        SC_FAIL(SC_EINPUT, "render: image size %d x %d px; allowed: 16 to 16384 px each way", width, height);
    struct render_renderer *r = calloc(1, sizeof *r);
    unsigned char *buffer = malloc((size_t)width * (size_t)height * 4);
    if (!r || !buffer) {
        free(r);
        free(buffer);
        SC_FAIL(SC_ESIM, "render: out of memory for a %d x %d image", width, height);
    }
    r->buffer = buffer, r->width = width, r->height = height;
    static const int attributes[] = {OSMESA_FORMAT, OSMESA_BGRA, OSMESA_DEPTH_BITS, 24, OSMESA_STENCIL_BITS, 0,
                                     OSMESA_PROFILE, OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, 3,
                                     OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
    r->context = OSMesaCreateContextAttribs(attributes, NULL);
    if (!r->context || !OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, width, height)) {
        render_renderer_destroy(r);
        SC_FAIL(SC_EIO, "render: cannot create an OSMesa GL 3.3 core context (is Mesa's libOSMesa installed?)");
    }
    OSMesaPixelStore(OSMESA_Y_UP, 0); /* row 0 of the buffer is the top row, as Cairo and PNG want it */
    int status = build_program(r);
    if (status != SC_OK) {
        render_renderer_destroy(r);
        return status;
    }
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
        OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, r->width, r->height);
        if (r->program) {
            glDeleteBuffers(1, &r->corner_buffer);
            glDeleteBuffers(1, &r->sphere_buffer);
            glDeleteBuffers(1, &r->colour_buffer);
            glDeleteVertexArrays(1, &r->vao);
            glDeleteProgram(r->program);
        }
        OSMesaDestroyContext(r->context);
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
    glViewport(0, 0, r->width, r->height);
    glClearColor(1, 1, 1, 1);
    glClearDepth(1);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glUseProgram(r->program);
    glUniform2f(r->viewport_location, (float)r->width, (float)r->height);
    glUniform1f(r->depth_location, (float)(1.0 / (cam->pixels_per_metre * cam->depth_half)));
    glBindVertexArray(r->vao);
    glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(n * 4 * sizeof *spheres), spheres, GL_STREAM_DRAW);
    glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
    glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(n * 4), colours, GL_STREAM_DRAW);
    /* in slices, so that one call never holds more vertices than llvmpipe's 32-bit counters like */
    const size_t slice = 1u << 20;
    for (size_t first = 0; first < n; first += slice) {
        size_t count = n - first < slice ? n - first : slice;
        glBindBuffer(GL_ARRAY_BUFFER, r->sphere_buffer);
        glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 0, (const void *)(first * 4 * sizeof *spheres));
        glBindBuffer(GL_ARRAY_BUFFER, r->colour_buffer);
        glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, 0, (const void *)(first * 4));
        glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, (GLsizei)count);
    }
    glFinish();
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
        SC_FAIL(SC_ESIM, "render: out of memory for %zu spheres", s->count);
    }
    size_t n = project_spheres(s, scene, &cam, spheres, colours);
    if (!OSMesaMakeCurrent(r->context, r->buffer, GL_UNSIGNED_BYTE, r->width, r->height)) {
        free(spheres);
        free(colours);
        SC_FAIL(SC_EIO, "render: cannot make the OSMesa context current");
    }
    draw_instances(r, spheres, colours, n, &cam);
    free(spheres);
    free(colours);
    GLenum error = glGetError();
    if (error != GL_NO_ERROR)
        SC_FAIL(SC_EIO, "render: OpenGL error 0x%x while drawing %zu spheres", (unsigned)error, n);
    SC_TRY(render_overlay_scene(&r->image, scene));
    if (cam_out)
        *cam_out = cam;
    *image = &r->image;
    return SC_OK;
}
