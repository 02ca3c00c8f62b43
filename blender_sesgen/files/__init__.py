"""Our own pure file formats: EXR and PNG codecs, image checks, contact sheets, dataset indexes."""
