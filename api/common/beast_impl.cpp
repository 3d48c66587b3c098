// Beast compiled once for the whole program (BOOST_BEAST_SEPARATE_COMPILATION is defined on gw_api).
#include <boost/beast/src.hpp>
