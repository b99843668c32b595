// validate.mjs FILE — checks an OpenAPI document against the OpenAPI 3.1
// schema with @seriousme/openapi-schema-validator (npm, package.json beside
// this file), and that every $ref resolves. Prints one JSON line:
// {"valid", "version", "errors"}; exit 0 when valid, 1 otherwise.
import { Validator } from "@seriousme/openapi-schema-validator";

const file = process.argv[2];
const validator = new Validator();
const res = await validator.validate(file);
let errors = res.errors || [];
if (res.valid) {
    try {
        validator.resolveRefs(); // throws on a $ref that points nowhere
    } catch (e) {
        errors = [{ message: `unresolved $ref: ${e.message}` }];
    }
}
const valid = res.valid && errors.length === 0;
console.log(JSON.stringify({ valid, version: validator.version, errors }));
process.exit(valid ? 0 : 1);
