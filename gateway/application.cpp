// placeholder, replaced by the application registry
