"""Dataset exports: one module per layout, registered in :data:`vo_reference.exporters.driver.EXPORTERS`; the file formats they share."""
