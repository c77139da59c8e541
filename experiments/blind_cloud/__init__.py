"""blind_cloud: see this folder's README.md."""
