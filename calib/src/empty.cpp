// Intentionally empty until this library's issue lands: CMake needs one source for a static library.
