"""kontur gateware: the patents' elements and the interpolator cores built from them."""
