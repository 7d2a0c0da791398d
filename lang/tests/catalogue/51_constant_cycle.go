// Constants defined in terms of each other.
package ConstCycle

const (
	A = B + 1
	B = A * 2
)

var D1 Quadcopter

func INIT() {
	D1.FlyByX(A)
}
