#include "sim/OsMesaRenderer.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <mutex>
#include <numeric>
#include <string>
#include <vector>

#include "common/Check.h"
#include "sim/Mesh.h"

namespace vln::sim {

namespace {

// Which images one pass writes (a bit set of Renderer::Output); also
// selects the shader variant.
using enum Renderer::Output;

// Everything nearer than this is clipped. Habitat's default near plane; the
// Embree backend has none, so the two differ only within 1 cm of the eye.
constexpr float kNearPlane = 0.01f;

// Colour attachments of the offscreen framebuffer, by fragment output
// location: colour (RGBA8), z-depth in metres (R32F) and object id (R32I).
constexpr GLenum kColorAttachment = GL_COLOR_ATTACHMENT0;
constexpr GLenum kDepthAttachment = GL_COLOR_ATTACHMENT1;
constexpr GLenum kObjectAttachment = GL_COLOR_ATTACHMENT2;

// ---------------------------------------------------------------------------
// shaders
// ---------------------------------------------------------------------------

constexpr const char* kVertexShader = R"(
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aColor;
layout(location = 2) in vec2 aUv;
uniform mat4 uViewProj;
out vec3 vColor;
out vec2 vUv;
void main() {
  vColor = aColor;
  vUv = aUv;
  gl_Position = uViewProj * vec4(aPosition, 1.0);
}
)";

// The same unlit rule as the Embree backend: base colour x vertex colour x
// bilinear texture. Depth is written as a float colour rather than read back
// from the depth buffer: clip-space w is the z-depth, so 1 / gl_FragCoord.w
// is exact to float precision, with none of the linearisation error of a
// non-linear depth buffer.
constexpr const char* kFragmentShader = R"(
in vec3 vColor;
in vec2 vUv;
uniform vec3 uBaseColor;
uniform bool uTextured;
uniform sampler2D uTexture;
uniform isamplerBuffer uObjects;
#if WRITE_COLOR
layout(location = 0) out vec4 outColor;
#endif
#if WRITE_DEPTH
layout(location = 1) out float outDepth;
#endif
#if WRITE_OBJECT
layout(location = 2) out int outObject;
#endif
void main() {
#if WRITE_COLOR
  vec3 color = uBaseColor * vColor;
  if (uTextured) color *= texture(uTexture, vUv).rgb;
  outColor = vec4(color, 1.0);
#endif
#if WRITE_DEPTH
  outDepth = 1.0 / gl_FragCoord.w;
#endif
#if WRITE_OBJECT
  outObject = texelFetch(uObjects, gl_PrimitiveID).r;
#endif
}
)";

// The info log of a shader or program object, read with the matching pair
// of GL calls (glGetShaderiv and glGetShaderInfoLog, or the program ones).
template <class GetParameter, class GetInfoLog>
std::string infoLog(GLuint object, GetParameter getParameter,
                    GetInfoLog getInfoLog) {
  GLint length = 0;
  getParameter(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<size_t>(std::max(length, 1)), '\0');
  getInfoLog(object, length, nullptr, log.data());
  return log;
}

std::string shaderLog(GLuint shader) {
  return infoLog(shader, glGetShaderiv, glGetShaderInfoLog);
}

std::string programLog(GLuint program) {
  return infoLog(program, glGetProgramiv, glGetProgramInfoLog);
}

GLuint compileShader(GLenum stage, const std::string& source) {
  GLuint shader = glCreateShader(stage);
  const char* text = source.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  // the sources are fixed, so a failure means the driver lacks a feature
  VLN_CHECK_IO(ok == GL_TRUE, "OsMesaRenderer: shader compilation failed: ",
               shaderLog(shader));
  return shader;
}

// uploads `bytes` of one vertex attribute array into `buffer` and enables
// it at `location`: `components` values of `type` per vertex, `stride`
// bytes apart
void uploadAttribute(GLuint buffer, GLuint location, const void* data,
                     size_t bytes, GLint components, GLenum type,
                     GLboolean normalized, GLsizei stride) {
  glBindBuffer(GL_ARRAY_BUFFER, buffer);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(bytes), data,
               GL_STATIC_DRAW);
  glVertexAttribPointer(location, components, type, normalized, stride,
                        nullptr);
  glEnableVertexAttribArray(location);
}

struct Program {
  GLuint id = 0;
  GLint viewProj = -1;
  GLint baseColor = -1;
  GLint textured = -1;
};

Program linkProgram(unsigned outputs) {
  const std::string header =
      strCat("#version 330 core\n#define WRITE_COLOR ", (outputs & kColor) ? 1 : 0,
             "\n#define WRITE_DEPTH ", (outputs & kDepth) ? 1 : 0,
             "\n#define WRITE_OBJECT ", (outputs & kObject) ? 1 : 0, "\n");
  GLuint vertex = compileShader(GL_VERTEX_SHADER,
                                "#version 330 core\n" + std::string(kVertexShader));
  GLuint fragment = compileShader(GL_FRAGMENT_SHADER, header + kFragmentShader);
  Program program;
  program.id = glCreateProgram();
  glAttachShader(program.id, vertex);
  glAttachShader(program.id, fragment);
  glLinkProgram(program.id);
  glDeleteShader(vertex);
  glDeleteShader(fragment);
  GLint ok = GL_FALSE;
  glGetProgramiv(program.id, GL_LINK_STATUS, &ok);
  VLN_CHECK_IO(ok == GL_TRUE, "OsMesaRenderer: shader link failed: ",
               programLog(program.id));
  program.viewProj = glGetUniformLocation(program.id, "uViewProj");
  program.baseColor = glGetUniformLocation(program.id, "uBaseColor");
  program.textured = glGetUniformLocation(program.id, "uTextured");
  // samplers are fixed to units 0 (material texture) and 1 (object ids)
  glUseProgram(program.id);
  glUniform1i(glGetUniformLocation(program.id, "uTexture"), 0);
  glUniform1i(glGetUniformLocation(program.id, "uObjects"), 1);
  return program;
}

void checkGl(const char* what) {
  const GLenum error = glGetError();
  VLN_CHECK_IO(error == GL_NO_ERROR, "OsMesaRenderer: OpenGL error 0x",
               std::hex, error, std::dec, " during ", what);
}

// ---------------------------------------------------------------------------
// OsMesaRenderer
// ---------------------------------------------------------------------------

// Held by whichever thread creates, uses or destroys an OSMesa context: the
// process renders with one context at a time. llvmpipe (Mesa 22.3) is not safe
// with contexts on several threads at once: before each read-back it asks
// every context of the process whether its pending scene uses the image,
// reading the other contexts' scenes while their threads change them (seen as
// crashes inside glReadPixels when two threads rendered panorama views), and
// OSMesaMakeCurrent() shares one unlocked list of buffers among all contexts.
// llvmpipe's own rasteriser threads (LP_NUM_THREADS) still use every core.
std::mutex& osMesaMutex() {
  static std::mutex mutex;
  return mutex;
}

struct ContextDeleter {
  void operator()(osmesa_context* context) const {
    std::lock_guard lock(osMesaMutex());
    // destroying the context frees every GL object created in it
    OSMesaDestroyContext(context);
  }
};

// A run of triangles (sorted by material) drawn with one material.
struct DrawGroup {
  size_t firstTriangle = 0;
  size_t triangleCount = 0;
  std::array<float, 3> baseColor{1.0f, 1.0f, 1.0f};
  GLuint texture = 0;  // 0 = untextured
};

class OsMesaRenderer final : public Renderer {
 public:
  explicit OsMesaRenderer(const TriangleMesh& mesh);

 private:
  // Takes osMesaMutex() and makes the context current on the calling thread
  // until it goes out of scope. The context is released again after each
  // call, as the panorama renderer hands its renderers to whichever pool
  // thread is free: a context left current on one thread would be flushed
  // from it when that thread next binds another.
  class Binding {
   public:
    explicit Binding(OsMesaRenderer& renderer);
    ~Binding();
    Binding(const Binding&) = delete;
    Binding& operator=(const Binding&) = delete;

   private:
    std::lock_guard<std::mutex> lock_;
  };
  void uploadMesh(const TriangleMesh& mesh);
  void ensureTarget(int width, int height);
  void render(const CameraPose& pose, const CameraIntrinsics& camera,
              unsigned outputs, uint8_t* rgb, float* depth,
              int32_t* objects) override;

  std::unique_ptr<osmesa_context, ContextDeleter> context_;
  // OSMesa needs a default colour buffer to make a context current; all
  // drawing goes to the framebuffer object below, so one pixel suffices
  std::array<uint8_t, 4> defaultBuffer_{};
  std::array<Program, 8> programs_{};  // indexed by the Output bit set
  GLuint vertexArray_ = 0;
  GLsizei indexCount_ = 0;
  std::vector<DrawGroup> groups_;
  GLuint framebuffer_ = 0;
  std::array<GLuint, 4> renderbuffers_{};  // colour, depth, object, z-buffer
  int targetWidth_ = 0;
  int targetHeight_ = 0;
};

OsMesaRenderer::OsMesaRenderer(const TriangleMesh& mesh)
    : Renderer("OsMesaRenderer", mesh) {
  // Renderer() has validated the mesh
  // a 3.3 core context; Mesa returns the highest version it supports with
  // that profile (4.5 with llvmpipe in Debian 12)
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            0,
                            OSMESA_STENCIL_BITS,
                            0,
                            OSMESA_ACCUM_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  {
    std::lock_guard lock(osMesaMutex());
    context_.reset(OSMesaCreateContextAttribs(attributes, nullptr));
  }
  VLN_CHECK_IO(context_ != nullptr,
               "OsMesaRenderer: OSMesaCreateContextAttribs could not create "
               "an OpenGL 3.3 core context (is libOSMesa's llvmpipe "
               "available?)");
  const Binding binding(*this);

  // reversed-Z needs glClipControl (GL 4.5 / ARB_clip_control): a float
  // depth buffer storing near/z keeps ~7 significant digits at every
  // distance, where the classic mapping loses centimetres beyond a few metres
  auto clipControl = reinterpret_cast<PFNGLCLIPCONTROLPROC>(
      OSMesaGetProcAddress("glClipControl"));
  GLint major = 0;
  GLint minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  VLN_CHECK_IO(clipControl != nullptr && (major > 4 || (major == 4 && minor >= 5)),
               "OsMesaRenderer: OpenGL 4.5 (glClipControl) is required, the "
               "OSMesa context offers ",
               major, ".", minor, " (",
               reinterpret_cast<const char*>(glGetString(GL_RENDERER)), ")");
  clipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
  glDisable(GL_CULL_FACE);
  glDisable(GL_DITHER);
  glDisable(GL_MULTISAMPLE);

  for (unsigned outputs : {unsigned{kColor}, unsigned{kDepth},
                            unsigned{kColor | kDepth}, unsigned{kObject}})
    programs_[outputs] = linkProgram(outputs);
  uploadMesh(mesh);
  checkGl("mesh upload");
}

OsMesaRenderer::Binding::Binding(OsMesaRenderer& renderer)
    : lock_(osMesaMutex()) {
  const GLboolean ok =
      OSMesaMakeCurrent(renderer.context_.get(), renderer.defaultBuffer_.data(),
                        GL_UNSIGNED_BYTE, 1, 1);
  VLN_CHECK_IO(ok == GL_TRUE, "OsMesaRenderer: OSMesaMakeCurrent failed");
}

OsMesaRenderer::Binding::~Binding() {
  // a null context and buffer release the calling thread's context
  OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
}

void OsMesaRenderer::uploadMesh(const TriangleMesh& mesh) {
  glGenVertexArrays(1, &vertexArray_);
  glBindVertexArray(vertexArray_);

  // vertex attributes: positions always, colours and uvs when present (the
  // constant attribute value stands in otherwise: white, uv 0)
  GLuint buffers[5];
  glGenBuffers(5, buffers);
  uploadAttribute(buffers[0], 0, mesh.positions.data(),
                  mesh.positions.size() * sizeof(float) * 3, 3, GL_FLOAT,
                  GL_FALSE, 3 * sizeof(float));
  if (!mesh.colors.empty()) {
    uploadAttribute(buffers[1], 1, mesh.colors.data(),
                    mesh.colors.size() * sizeof(Rgb8), 3, GL_UNSIGNED_BYTE,
                    GL_TRUE, sizeof(Rgb8));
  } else {
    glVertexAttrib3f(1, 1.0f, 1.0f, 1.0f);
  }
  if (!mesh.uvs.empty()) {
    uploadAttribute(buffers[2], 2, mesh.uvs.data(),
                    mesh.uvs.size() * sizeof(float) * 2, 2, GL_FLOAT, GL_FALSE,
                    2 * sizeof(float));
  } else {
    glVertexAttrib2f(2, 0.0f, 0.0f);
  }

  // triangles sorted by material so each material is one draw call
  const size_t triangles = mesh.triangleCount();
  auto materialOf = [&](size_t t) {
    return mesh.triangle_material.empty() ? -1 : mesh.triangle_material[t];
  };
  std::vector<uint32_t> order(triangles);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return materialOf(a) < materialOf(b);
  });
  std::vector<uint32_t> sortedIndices(triangles * 3);
  std::vector<int32_t> sortedObjects(triangles, -1);
  for (size_t k = 0; k < triangles; ++k) {
    const size_t t = order[k];
    std::copy_n(mesh.indices.begin() + static_cast<std::ptrdiff_t>(3 * t), 3,
                sortedIndices.begin() + static_cast<std::ptrdiff_t>(3 * k));
    if (!mesh.triangle_object.empty()) sortedObjects[k] = mesh.triangle_object[t];
  }
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, buffers[3]);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(sortedIndices.size() * sizeof(uint32_t)),
               sortedIndices.data(), GL_STATIC_DRAW);
  indexCount_ = static_cast<GLsizei>(sortedIndices.size());

  // object id per triangle in draw order: gl_PrimitiveID indexes it
  GLint maxTexels = 0;
  glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &maxTexels);
  VLN_CHECK_IO(triangles <= static_cast<size_t>(maxTexels),
               "OsMesaRenderer: ", triangles,
               " triangles exceed the texture buffer limit of ", maxTexels);
  glBindBuffer(GL_TEXTURE_BUFFER, buffers[4]);
  glBufferData(GL_TEXTURE_BUFFER,
               static_cast<GLsizeiptr>(sortedObjects.size() * sizeof(int32_t)),
               sortedObjects.data(), GL_STATIC_DRAW);
  GLuint objectTexture = 0;
  glGenTextures(1, &objectTexture);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_BUFFER, objectTexture);
  glTexBuffer(GL_TEXTURE_BUFFER, GL_R32I, buffers[4]);
  glActiveTexture(GL_TEXTURE0);

  // textures: bilinear, repeat, no mipmaps (the ray caster samples the same
  // way); row 0 of the image is t = 0 as in the mesh's uv convention
  std::vector<GLuint> textures(mesh.textures.size());
  if (!textures.empty())
    glGenTextures(static_cast<GLsizei>(textures.size()), textures.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (size_t i = 0; i < mesh.textures.size(); ++i) {
    const Texture& texture = mesh.textures[i];
    glBindTexture(GL_TEXTURE_2D, textures[i]);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, texture.width, texture.height, 0,
                 GL_RGB, GL_UNSIGNED_BYTE, texture.rgb.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  }

  // one draw group per run of equal material
  for (size_t k = 0; k < triangles;) {
    const int material = materialOf(order[k]);
    size_t end = k;
    while (end < triangles && materialOf(order[end]) == material) ++end;
    DrawGroup group;
    group.firstTriangle = k;
    group.triangleCount = end - k;
    if (material >= 0) {
      const Material& m = mesh.materials[static_cast<size_t>(material)];
      group.baseColor = m.base_color;
      if (m.texture >= 0) group.texture = textures[static_cast<size_t>(m.texture)];
    }
    groups_.push_back(group);
    k = end;
  }
}

void OsMesaRenderer::ensureTarget(int width, int height) {
  if (width == targetWidth_ && height == targetHeight_) return;
  if (framebuffer_ == 0) {
    glGenFramebuffers(1, &framebuffer_);
    glGenRenderbuffers(static_cast<GLsizei>(renderbuffers_.size()),
                       renderbuffers_.data());
  }
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  const std::array<std::pair<GLenum, GLenum>, 4> layout = {{
      {GL_RGBA8, kColorAttachment},
      {GL_R32F, kDepthAttachment},
      {GL_R32I, kObjectAttachment},
      {GL_DEPTH_COMPONENT32F, GL_DEPTH_ATTACHMENT},
  }};
  for (size_t i = 0; i < layout.size(); ++i) {
    glBindRenderbuffer(GL_RENDERBUFFER, renderbuffers_[i]);
    glRenderbufferStorage(GL_RENDERBUFFER, layout[i].first, width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, layout[i].second, GL_RENDERBUFFER,
                              renderbuffers_[i]);
  }
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  VLN_CHECK_IO(status == GL_FRAMEBUFFER_COMPLETE,
               "OsMesaRenderer: framebuffer of ", width, "x", height,
               " is incomplete (status 0x", std::hex, status, ")");
  checkGl("framebuffer setup");
  targetWidth_ = width;
  targetHeight_ = height;
}

void OsMesaRenderer::render(const CameraPose& pose,
                            const CameraIntrinsics& camera, unsigned outputs,
                            uint8_t* rgb, float* depth, int32_t* objects) {
  const Binding binding(*this);
  ensureTarget(camera.width, camera.height);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  glViewport(0, 0, camera.width, camera.height);

  // only the requested attachments are drawn to and cleared
  const GLenum drawBuffers[3] = {
      (outputs & kColor) ? kColorAttachment : GLenum{GL_NONE},
      (outputs & kDepth) ? kDepthAttachment : GLenum{GL_NONE},
      (outputs & kObject) ? kObjectAttachment : GLenum{GL_NONE}};
  glDrawBuffers(3, drawBuffers);
  const float black[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const GLint noObject[4] = {-1, -1, -1, -1};
  const float farDepth = 0.0f;  // reversed Z: 0 is infinitely far
  if (outputs & kColor) glClearBufferfv(GL_COLOR, 0, black);
  if (outputs & kDepth) glClearBufferfv(GL_COLOR, 1, black);
  if (outputs & kObject) glClearBufferiv(GL_COLOR, 2, noObject);
  glClearBufferfv(GL_DEPTH, 0, &farDepth);

  // view-projection: world to camera (R^T (p - eye)), then an infinite
  // reversed-Z perspective. The y row is negated so that GL's bottom-up
  // framebuffer holds the top image row in row 0 and reads back in the
  // caller's top-first order with no flip.
  const Eigen::Matrix3f toWorld = cameraToWorld(pose);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.topLeftCorner<3, 3>() = toWorld.transpose();
  view.topRightCorner<3, 1>() = -toWorld.transpose() * pose.eye;
  const float tanX = std::tan(degToRad(camera.hfov_deg) / 2.0f);
  const float tanY = tanHalfVerticalFov(camera);
  Eigen::Matrix4f projection = Eigen::Matrix4f::Zero();
  projection(0, 0) = 1.0f / tanX;
  projection(1, 1) = -1.0f / tanY;
  projection(2, 3) = kNearPlane;
  projection(3, 2) = -1.0f;
  const Eigen::Matrix4f viewProj = projection * view;

  const Program& program = programs_[outputs];
  VLN_ASSERT(program.id != 0);
  glUseProgram(program.id);
  // Eigen is column-major, as GL expects
  glUniformMatrix4fv(program.viewProj, 1, GL_FALSE, viewProj.data());
  glBindVertexArray(vertexArray_);
  if (outputs & kColor) {
    for (const DrawGroup& group : groups_) {
      glUniform3fv(program.baseColor, 1, group.baseColor.data());
      glUniform1i(program.textured, group.texture != 0 ? 1 : 0);
      if (group.texture != 0) glBindTexture(GL_TEXTURE_2D, group.texture);
      glDrawElements(
          GL_TRIANGLES, static_cast<GLsizei>(group.triangleCount * 3),
          GL_UNSIGNED_INT,
          reinterpret_cast<const void*>(group.firstTriangle * 3 * sizeof(uint32_t)));
    }
  } else {
    // depth and ids ignore materials: one draw, so gl_PrimitiveID counts
    // from the first triangle and indexes the object table directly
    glDrawElements(GL_TRIANGLES, indexCount_, GL_UNSIGNED_INT, nullptr);
  }

  // read back into the caller's buffers (rows are already top-first)
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  if (outputs & kColor) {
    glReadBuffer(kColorAttachment);
    glReadPixels(0, 0, camera.width, camera.height, GL_RGB, GL_UNSIGNED_BYTE, rgb);
  }
  if (outputs & kDepth) {
    glReadBuffer(kDepthAttachment);
    glReadPixels(0, 0, camera.width, camera.height, GL_RED, GL_FLOAT, depth);
  }
  if (outputs & kObject) {
    glReadBuffer(kObjectAttachment);
    glReadPixels(0, 0, camera.width, camera.height, GL_RED_INTEGER, GL_INT,
                 objects);
  }
  checkGl("rendering");
}

}  // namespace

std::unique_ptr<Renderer> createOsMesaRenderer(const TriangleMesh& mesh) {
  return std::make_unique<OsMesaRenderer>(mesh);
}

}  // namespace vln::sim
