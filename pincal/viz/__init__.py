"""Pictures: plots, the meshcat scene, static pages, the HTML report."""
