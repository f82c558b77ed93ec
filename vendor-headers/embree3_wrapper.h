/* The part of Embree 3's C API that caustix binds to (through bindgen in build.rs).
 * Debian 12: `apt-get install libembree-dev` puts this header in /usr/include/embree3. */
#include <embree3/rtcore.h>
