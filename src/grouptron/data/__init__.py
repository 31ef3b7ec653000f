"""Reading, validating, downloading and preprocessing the ETH/UCY benchmark."""
