// The one translation unit that compiles Asio's implementation (BOOST_ASIO_SEPARATE_COMPILATION),
// so the rest of the project includes only declarations and builds quickly on two cores.
#include <boost/asio/impl/src.hpp>
