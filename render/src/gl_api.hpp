#pragma once
// OSMesa and the OpenGL functions the renderer calls, through pointers filled when the first context
// is made (loadGl()), the way GL loaders (glad, GLEW) do it: libOSMesa brings LLVM, whose loading took
// about 0.05 s of every start of a program that links it, a tracker log's diagnosis as much as a render.
// Include this header, never GL/osmesa.h alone, in the renderer's sources: after it, glClear(...) and
// the rest name the pointers (the macros below).
#include <GL/osmesa.h>

// Every function the renderer calls, OSMesa's first. A new GL call needs its name here and below.
#define ORBCAL_GL_FUNCTIONS(X) \
  X(OSMesaCreateContextAttribs) \
  X(OSMesaMakeCurrent) \
  X(OSMesaDestroyContext) \
  X(OSMesaGetCurrentContext) \
  X(glActiveTexture) \
  X(glAttachShader) \
  X(glBindBuffer) \
  X(glBindFramebuffer) \
  X(glBindRenderbuffer) \
  X(glBindTexture) \
  X(glBindVertexArray) \
  X(glBlitFramebuffer) \
  X(glBufferData) \
  X(glCheckFramebufferStatus) \
  X(glClear) \
  X(glClearColor) \
  X(glClearDepth) \
  X(glCompileShader) \
  X(glCreateProgram) \
  X(glCreateShader) \
  X(glDeleteBuffers) \
  X(glDeleteFramebuffers) \
  X(glDeleteProgram) \
  X(glDeleteRenderbuffers) \
  X(glDeleteShader) \
  X(glDeleteTextures) \
  X(glDeleteVertexArrays) \
  X(glDepthFunc) \
  X(glDisable) \
  X(glDrawArrays) \
  X(glDrawBuffer) \
  X(glEnable) \
  X(glEnableVertexAttribArray) \
  X(glFinish) \
  X(glFramebufferRenderbuffer) \
  X(glFramebufferTexture2D) \
  X(glGenBuffers) \
  X(glGenFramebuffers) \
  X(glGenRenderbuffers) \
  X(glGenTextures) \
  X(glGenVertexArrays) \
  X(glGenerateMipmap) \
  X(glGetError) \
  X(glGetIntegerv) \
  X(glGetProgramInfoLog) \
  X(glGetProgramiv) \
  X(glGetShaderInfoLog) \
  X(glGetShaderiv) \
  X(glGetString) \
  X(glGetUniformLocation) \
  X(glLinkProgram) \
  X(glPixelStorei) \
  X(glPolygonOffset) \
  X(glReadBuffer) \
  X(glReadPixels) \
  X(glRenderbufferStorageMultisample) \
  X(glShaderSource) \
  X(glTexImage2D) \
  X(glTexParameteri) \
  X(glUniform1f) \
  X(glUniform1i) \
  X(glUniform3fv) \
  X(glUniform4f) \
  X(glUniformMatrix4fv) \
  X(glUseProgram) \
  X(glVertexAttribPointer) \
  X(glViewport)

#define ORBCAL_GL_DECLARE(name) extern decltype(&::name) orbcal_gl_##name;
ORBCAL_GL_FUNCTIONS(ORBCAL_GL_DECLARE)
#undef ORBCAL_GL_DECLARE

namespace orbcal::render {
/// Opens OSMesa (ORBCAL_OSMESA_LIBRARY, the library found at configure time) and fills the pointers,
/// once; throws std::runtime_error naming the library and the missing symbol where it cannot.
void loadGl();
}  // namespace orbcal::render

#define OSMesaCreateContextAttribs orbcal_gl_OSMesaCreateContextAttribs
#define OSMesaMakeCurrent orbcal_gl_OSMesaMakeCurrent
#define OSMesaDestroyContext orbcal_gl_OSMesaDestroyContext
#define OSMesaGetCurrentContext orbcal_gl_OSMesaGetCurrentContext
#define glActiveTexture orbcal_gl_glActiveTexture
#define glAttachShader orbcal_gl_glAttachShader
#define glBindBuffer orbcal_gl_glBindBuffer
#define glBindFramebuffer orbcal_gl_glBindFramebuffer
#define glBindRenderbuffer orbcal_gl_glBindRenderbuffer
#define glBindTexture orbcal_gl_glBindTexture
#define glBindVertexArray orbcal_gl_glBindVertexArray
#define glBlitFramebuffer orbcal_gl_glBlitFramebuffer
#define glBufferData orbcal_gl_glBufferData
#define glCheckFramebufferStatus orbcal_gl_glCheckFramebufferStatus
#define glClear orbcal_gl_glClear
#define glClearColor orbcal_gl_glClearColor
#define glClearDepth orbcal_gl_glClearDepth
#define glCompileShader orbcal_gl_glCompileShader
#define glCreateProgram orbcal_gl_glCreateProgram
#define glCreateShader orbcal_gl_glCreateShader
#define glDeleteBuffers orbcal_gl_glDeleteBuffers
#define glDeleteFramebuffers orbcal_gl_glDeleteFramebuffers
#define glDeleteProgram orbcal_gl_glDeleteProgram
#define glDeleteRenderbuffers orbcal_gl_glDeleteRenderbuffers
#define glDeleteShader orbcal_gl_glDeleteShader
#define glDeleteTextures orbcal_gl_glDeleteTextures
#define glDeleteVertexArrays orbcal_gl_glDeleteVertexArrays
#define glDepthFunc orbcal_gl_glDepthFunc
#define glDisable orbcal_gl_glDisable
#define glDrawArrays orbcal_gl_glDrawArrays
#define glDrawBuffer orbcal_gl_glDrawBuffer
#define glEnable orbcal_gl_glEnable
#define glEnableVertexAttribArray orbcal_gl_glEnableVertexAttribArray
#define glFinish orbcal_gl_glFinish
#define glFramebufferRenderbuffer orbcal_gl_glFramebufferRenderbuffer
#define glFramebufferTexture2D orbcal_gl_glFramebufferTexture2D
#define glGenBuffers orbcal_gl_glGenBuffers
#define glGenFramebuffers orbcal_gl_glGenFramebuffers
#define glGenRenderbuffers orbcal_gl_glGenRenderbuffers
#define glGenTextures orbcal_gl_glGenTextures
#define glGenVertexArrays orbcal_gl_glGenVertexArrays
#define glGenerateMipmap orbcal_gl_glGenerateMipmap
#define glGetError orbcal_gl_glGetError
#define glGetIntegerv orbcal_gl_glGetIntegerv
#define glGetProgramInfoLog orbcal_gl_glGetProgramInfoLog
#define glGetProgramiv orbcal_gl_glGetProgramiv
#define glGetShaderInfoLog orbcal_gl_glGetShaderInfoLog
#define glGetShaderiv orbcal_gl_glGetShaderiv
#define glGetString orbcal_gl_glGetString
#define glGetUniformLocation orbcal_gl_glGetUniformLocation
#define glLinkProgram orbcal_gl_glLinkProgram
#define glPixelStorei orbcal_gl_glPixelStorei
#define glPolygonOffset orbcal_gl_glPolygonOffset
#define glReadBuffer orbcal_gl_glReadBuffer
#define glReadPixels orbcal_gl_glReadPixels
#define glRenderbufferStorageMultisample orbcal_gl_glRenderbufferStorageMultisample
#define glShaderSource orbcal_gl_glShaderSource
#define glTexImage2D orbcal_gl_glTexImage2D
#define glTexParameteri orbcal_gl_glTexParameteri
#define glUniform1f orbcal_gl_glUniform1f
#define glUniform1i orbcal_gl_glUniform1i
#define glUniform3fv orbcal_gl_glUniform3fv
#define glUniform4f orbcal_gl_glUniform4f
#define glUniformMatrix4fv orbcal_gl_glUniformMatrix4fv
#define glUseProgram orbcal_gl_glUseProgram
#define glVertexAttribPointer orbcal_gl_glVertexAttribPointer
#define glViewport orbcal_gl_glViewport
