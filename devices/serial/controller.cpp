// placeholder, replaced by the serial driver
