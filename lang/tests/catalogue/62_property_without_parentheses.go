// A property is read with parentheses, like a Go method call.
package PropertyParens

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.Z > 1, SEQ_Go)
}

func SEQ_Go() {
	D1.FlyByX(1)
}
