// Internal: the OpenGL 3.3 core functions penumbra's GL layer calls, loaded by name through the
// current context's EGL or OSMesa getProcAddress (no link-time dependency on libGL: the library
// dlopens EGL and OSMesa, so a machine without them still runs the OpenCL-only path).
#pragma once
#include <GL/glcorearb.h>

#include <string>

#include "penumbra/gl/context.hpp"

namespace penumbra::gl::detail {

#define PB_GL_FUNCTIONS(X)                                                                     \
  X(PFNGLGETERRORPROC, GetError)                                                               \
  X(PFNGLGETSTRINGPROC, GetString)                                                             \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                                                         \
  X(PFNGLISTEXTUREPROC, IsTexture)                                                             \
  X(PFNGLGENTEXTURESPROC, GenTextures)                                                         \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                                   \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                                                         \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                                     \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                                     \
  X(PFNGLGETTEXLEVELPARAMETERIVPROC, GetTexLevelParameteriv)                                   \
  X(PFNGLGETTEXIMAGEPROC, GetTexImage)                                                         \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                                           \
  X(PFNGLTEXIMAGE3DPROC, TexImage3D)                                                           \
  X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D)                                                     \
  X(PFNGLTEXSUBIMAGE3DPROC, TexSubImage3D)                                                     \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                         \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                                 \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                           \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                                 \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)                                       \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                                   \
  X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                                                         \
  X(PFNGLREADBUFFERPROC, ReadBuffer)                                                           \
  X(PFNGLVIEWPORTPROC, Viewport)                                                               \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                                                     \
  X(PFNGLENABLEPROC, Enable)                                                                   \
  X(PFNGLDISABLEPROC, Disable)                                                                 \
  X(PFNGLISENABLEDPROC, IsEnabled)                                                             \
  X(PFNGLDEPTHFUNCPROC, DepthFunc)                                                             \
  X(PFNGLDEPTHMASKPROC, DepthMask)                                                             \
  X(PFNGLCREATESHADERPROC, CreateShader)                                                       \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                                                       \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                                                     \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                         \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                               \
  X(PFNGLDELETESHADERPROC, DeleteShader)                                                       \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                                     \
  X(PFNGLATTACHSHADERPROC, AttachShader)                                                       \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                         \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                                       \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                             \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                                     \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                                                           \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                           \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                                                             \
  X(PFNGLUNIFORM1FPROC, Uniform1f)                                                             \
  X(PFNGLUNIFORM2FPROC, Uniform2f)                                                             \
  X(PFNGLUNIFORM3FPROC, Uniform3f)                                                             \
  X(PFNGLUNIFORM3FVPROC, Uniform3fv)                                                           \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                                               \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                                 \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                           \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                                 \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                                                           \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                                     \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                                                           \
  X(PFNGLBUFFERDATAPROC, BufferData)                                                           \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                                         \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                                 \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                                                           \
  X(PFNGLGENSAMPLERSPROC, GenSamplers)                                                         \
  X(PFNGLDELETESAMPLERSPROC, DeleteSamplers)                                                   \
  X(PFNGLSAMPLERPARAMETERIPROC, SamplerParameteri)                                             \
  X(PFNGLBINDSAMPLERPROC, BindSampler)                                                         \
  X(PFNGLGETUNIFORMBLOCKINDEXPROC, GetUniformBlockIndex)                                       \
  X(PFNGLUNIFORMBLOCKBINDINGPROC, UniformBlockBinding)                                         \
  X(PFNGLBINDBUFFERBASEPROC, BindBufferBase)                                                   \
  X(PFNGLFINISHPROC, Finish)

struct GLFunctions {
#define PB_GL_DECLARE(type, name) type name = nullptr;
  PB_GL_FUNCTIONS(PB_GL_DECLARE)
#undef PB_GL_DECLARE
  // Loads every function through `loader`; throws Error(NoPlatform) naming the first one missing.
  void load(ProcLoader loader);
  // Throws Error(Device) with `what` and the GL error name if glGetError reports one.
  void check(const std::string& what) const;
  // Compiles and links a vertex + fragment program; throws Error(Internal) with the log.
  GLuint program(const std::string& name, const std::string& vertex,
                 const std::string& fragment) const;
};

// GLSL sources embedded at build time (src/gl/shaders/*, cmake/embed_glsl.cmake), by file name.
const std::string& shaderSource(const std::string& file);

}  // namespace penumbra::gl::detail
